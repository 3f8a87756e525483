// Grid-point repelling (core/cutting/repel.h, Awad et al. 2016 Section 2.2) on uniform grids
// with analytic SDFs. Asserted against crossings recomputed here from the returned values: every
// crossing ends at least delta from both of its edge's points, or the near point is reported
// pinned; no point changes its sign; the returned values are the SDF at the returned points;
// moves run along one grid line, within the cap (off-line moves: within their cap, |f| grown),
// and points on the padded cube's faces stay on them; a plane's one predicted move is exact; the
// off-line rounds leave fewer points pinned; the result is the same on 1 thread and on many;
// relax_cells halves moves, then gives the grid back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/repel.h"
#include "core/grid/complex_topology.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

struct Case {
  HexComplex cx;
  Box cube;
  std::vector<double> values;
  SdfBatch sdf;
};

Case sphere_case(int depth) {
  static const ShapeSdf sdf(ShapeKind::kSphere);
  Case c;
  c.cube = padded_cube(sdf.bounds(), 0.1);
  c.cx = uniform_complex(UniformGrid(c.cube, depth));
  c.values.resize(c.cx.points.size());
  sdf.evaluate(c.cx.points, c.values);
  c.sdf = [](std::span<const Vec3> p, std::span<double> v) { sdf.evaluate(p, v); };
  return c;
}

// Inside where x < x0: a plane that crosses the x edges only.
Case plane_case(int depth, double x0) {
  Case c;
  c.cube = Box{{-1, -1, -1}, {1, 1, 1}};
  c.cx = uniform_complex(UniformGrid(c.cube, depth));
  c.sdf = [x0](std::span<const Vec3> p, std::span<double> v) {
    for (std::size_t i = 0; i < p.size(); ++i) v[i] = x0 - p[i].x;
  };
  c.values.resize(c.cx.points.size());
  c.sdf(c.cx.points, c.values);
  return c;
}

bool inside(double tiny, double v) { return v >= tiny; }

// exact: the crossings are the field's own zeros on the edges (RepelOptions::exact_crossings).
void expect_rules_hold(const Case& c, const Repelled& r, double delta, bool exact = false) {
  const double tiny = zero_tolerance_of(c.cx);
  const double h = c.cx.cell_size.empty() ? 0 : c.cx.cell_size[0];
  // No sign changes, and the values are the SDF at the points.
  std::vector<double> fresh(r.points.size());
  c.sdf(r.points, fresh);
  std::size_t moved = 0, pinned = 0, off_line = 0;
  for (std::size_t p = 0; p < r.points.size(); ++p) {
    ASSERT_EQ(inside(tiny, r.values[p]), inside(tiny, c.values[p])) << "point " << p << " changed sign";
    ASSERT_EQ(r.values[p], fresh[p]) << "point " << p;
    const Vec3 o = c.cx.points[p], d = r.points[p] - o;
    const int axes = (d.x != 0) + (d.y != 0) + (d.z != 0);
    off_line += r.off_line[p];
    if (r.off_line[p]) {
      ASSERT_LE(norm(d), kOffLineCap * 0.45 * h * (1 + 1e-12)) << "point " << p;
    } else {
      ASSERT_LE(axes, 1) << "point " << p << " left its grid lines";
      ASSERT_LE(norm(d), 0.45 * h * (1 + 1e-12)) << "point " << p;
    }
    for (int i = 0; i < 3; ++i)
      if (o[i] == c.cube.lo[i] || o[i] == c.cube.hi[i]) {
        ASSERT_EQ(r.points[p][i], o[i]) << "point " << p << " left a face";
      }
    moved += axes >= 1;
    pinned += r.state[p] == RepelState::kPinned;
    if (axes >= 1) {
      ASSERT_NE(r.state[p], RepelState::kStill);
    }
  }
  EXPECT_EQ(r.stats.moved, moved);
  EXPECT_EQ(r.stats.pinned, pinned);
  EXPECT_EQ(r.stats.off_line, off_line);
  // Every crossing delta from both ends, or the near end pinned.
  const ComplexTopology topo = build_topology(c.cx);
  std::vector<double> zeros(topo.edge_points.size());
  if (exact) search_crossings(r.points, topo.edge_points, r.values, tiny, c.sdf, {}, zeros);
  std::size_t crossings = 0;
  for (std::size_t id = 0; id < topo.edge_points.size(); ++id) {
    const auto& e = topo.edge_points[id];
    auto rule = [&](double v) { return std::abs(v) < tiny ? -tiny : v; };
    const double fa = rule(r.values[e[0]]), fb = rule(r.values[e[1]]);
    if ((fa > 0) == (fb > 0)) continue;
    ++crossings;
    const double t = exact ? zeros[id] : fa / (fa - fb);
    if (t < delta - 1e-9) {
      EXPECT_EQ(r.state[e[0]], RepelState::kPinned) << "edge " << e[0] << "-" << e[1] << " t " << t;
    }
    if (1 - t < delta - 1e-9) {
      EXPECT_EQ(r.state[e[1]], RepelState::kPinned) << "edge " << e[0] << "-" << e[1] << " t " << t;
    }
  }
  EXPECT_GT(crossings, 0u);
}

TEST(Repel, SphereCrossingsClearOrPinned) {
  for (double delta : {0.1, 0.25, 0.45})
    for (int off_line_rounds : {0, 4}) {
      const Case c = sphere_case(3);
      RepelOptions o;
      o.delta = delta;
      o.off_line_rounds = off_line_rounds;
      const Repelled r = repel(c.cx, c.cube, c.values, c.sdf, o);
      EXPECT_GT(r.stats.moved, 0u) << delta;
      EXPECT_GE(r.stats.rounds, 1);
      EXPECT_LE(r.stats.rounds, 4);
      EXPECT_LE(r.stats.off_line_rounds, off_line_rounds);
      expect_rules_hold(c, r, delta);
    }
}

// Measured at the field's own zeros (what `--crossings exact` cuts at), the rules hold for those:
// every exact crossing DELTA from both ends or its near end pinned. The linear rule's result
// does not give that on the sphere (its crossings sit on chords, inside the exact ones).
TEST(Repel, ExactCrossingsClearOrPinned) {
  for (double delta : {0.1, 0.25}) {
    const Case c = sphere_case(3);
    RepelOptions o;
    o.delta = delta;
    o.exact_crossings = true;
    const Repelled r = repel(c.cx, c.cube, c.values, c.sdf, o);
    EXPECT_GT(r.stats.moved, 0u) << delta;
    expect_rules_hold(c, r, delta, true);
    // The linear rule's points: some exact crossing ends nearer than DELTA to a point that is
    // not pinned (a sphere's field is concave along a line, so its zero lies beyond the chord's).
    const Repelled linear = repel(c.cx, c.cube, c.values, c.sdf, RepelOptions{delta});
    const ComplexTopology topo = build_topology(c.cx);
    std::vector<double> zeros(topo.edge_points.size());
    const double tiny = zero_tolerance_of(c.cx);
    search_crossings(linear.points, topo.edge_points, linear.values, tiny, c.sdf, {}, zeros);
    std::size_t short_of_delta = 0;
    for (std::size_t id = 0; id < zeros.size(); ++id) {
      if (std::isnan(zeros[id])) continue;
      const auto& e = topo.edge_points[id];
      short_of_delta += (zeros[id] < delta - 1e-9 && linear.state[e[0]] != RepelState::kPinned) ||
                        (1 - zeros[id] < delta - 1e-9 && linear.state[e[1]] != RepelState::kPinned);
    }
    EXPECT_GT(short_of_delta, 0u) << delta;
  }
}

// The off-line rounds start where the grid-line rounds end (the run without them), and move
// only points they left asking: each such point ends farther from the isosurface than it was
// there (|f| grew), at the same sign; fewer points stay pinned.
TEST(Repel, OffLineRoundsServeWhatTheGridLinesLeave) {
  for (int depth : {3, 4}) {
    const Case c = sphere_case(depth);
    RepelOptions grid_only;
    grid_only.off_line_rounds = 0;
    const Repelled before = repel(c.cx, c.cube, c.values, c.sdf, grid_only);
    const Repelled after = repel(c.cx, c.cube, c.values, c.sdf);
    expect_rules_hold(c, after, 0.25);
    EXPECT_EQ(before.stats.off_line, 0u);
    EXPECT_GT(after.stats.off_line, 0u) << depth;
    EXPECT_LT(after.stats.pinned, before.stats.pinned) << depth;
    for (std::size_t p = 0; p < c.cx.points.size(); ++p) {
      if (!after.off_line[p]) {
        EXPECT_EQ(after.points[p].x, before.points[p].x) << p;
        EXPECT_EQ(after.points[p].y, before.points[p].y) << p;
        EXPECT_EQ(after.points[p].z, before.points[p].z) << p;
        continue;
      }
      EXPECT_EQ(before.state[p], RepelState::kPinned) << p;
      EXPECT_GT(std::abs(after.values[p]), std::abs(before.values[p])) << p;
    }
  }
}

// A plane 0.1 h past grid points of column i: t = 0.1 from them, so each moves by
// (0.25 - 0.1) h / 0.75 = 0.2 h away, and the linear field puts the crossing at exactly 0.25
// of the longer edge. Nothing else moves; nothing is pinned.
TEST(Repel, PlaneMoveIsExact) {
  const int depth = 2;  // 9 cells per axis on [-1, 1]
  const double h = 2.0 / 9;
  const double xi = -1 + 4 * h;
  const Case c = plane_case(depth, xi + 0.1 * h);
  const Repelled r = repel(c.cx, c.cube, c.values, c.sdf, {0.25});
  expect_rules_hold(c, r, 0.25);
  EXPECT_EQ(r.stats.pinned, 0u);
  EXPECT_EQ(r.stats.rounds, 1);
  EXPECT_EQ(r.stats.moved, 10u * 10u);
  for (std::size_t p = 0; p < r.points.size(); ++p) {
    const Vec3 o = c.cx.points[p];
    if (std::abs(o.x - xi) < 1e-12) {
      EXPECT_NEAR(r.points[p].x, xi - 0.2 * h, 1e-12) << p;
    } else {
      EXPECT_EQ(r.points[p].x, o.x) << p;
    }
    EXPECT_EQ(r.points[p].y, o.y);
    EXPECT_EQ(r.points[p].z, o.z);
  }
}

// A plane 0.1 h inside the cube's face x = -1: those face points would have to leave the cube,
// so they stay and are pinned.
TEST(Repel, CubeFacePointsStayOnTheirFace) {
  const double h = 2.0 / 9;
  const Case c = plane_case(2, -1 + 0.1 * h);
  const Repelled r = repel(c.cx, c.cube, c.values, c.sdf, {0.25});
  expect_rules_hold(c, r, 0.25);
  EXPECT_EQ(r.stats.moved, 0u);
  EXPECT_EQ(r.stats.pinned, 10u * 10u);
}

// relax_cells halves a moved corner's move kMaxRelaxHalvings times (the SDF re-evaluated there),
// then gives the grid position back; points outside the cells are untouched.
TEST(Repel, RelaxCellsHalvesThenRestores) {
  const double h = 2.0 / 9;
  const double xi = -1 + 4 * h;
  const Case c = plane_case(2, xi + 0.1 * h);
  Repelled r = repel(c.cx, c.cube, c.values, c.sdf, {0.25});
  ASSERT_EQ(r.stats.moved, 100u);
  // One cell with corners on column i (x = xi), named three times in the list (repeats do not
  // count twice).
  std::uint32_t cell = 0;
  while (std::abs(c.cx.points[c.cx.cells[cell][1]].x - xi) > 1e-12) ++cell;
  const std::vector<std::uint32_t> one = {cell, cell, cell};
  const Repelled before = r;
  std::vector<std::uint32_t> corners;
  for (std::uint32_t p : c.cx.cells[cell])
    if (std::abs(c.cx.points[p].x - xi) < 1e-12) corners.push_back(p);
  ASSERT_EQ(corners.size(), 4u);
  double expected = 0.2 * h;
  for (int k = 0; k < kMaxRelaxHalvings; ++k) {
    EXPECT_EQ(relax_cells(c.cx, c.values, one, c.sdf, r), 4u);
    expected /= 2;
    for (std::uint32_t p : corners) {
      EXPECT_NEAR(c.cx.points[p].x - r.points[p].x, expected, 1e-12);
      EXPECT_EQ(r.values[p], xi + 0.1 * h - r.points[p].x);
      EXPECT_EQ(r.state[p], RepelState::kPinned);  // its crossing is nearer than delta again
    }
  }
  EXPECT_EQ(r.stats.pinned, before.stats.pinned + 4);
  for (std::size_t p = 0; p < r.points.size(); ++p)
    if (std::find(corners.begin(), corners.end(), p) == corners.end()) {
      EXPECT_EQ(r.points[p].x, before.points[p].x) << p;
      EXPECT_EQ(r.values[p], before.values[p]) << p;
    }
  EXPECT_EQ(r.stats.relaxed, 4u * kMaxRelaxHalvings);
  EXPECT_EQ(relax_cells(c.cx, c.values, one, c.sdf, r), 4u);
  for (std::uint32_t p : corners) {
    EXPECT_EQ(r.points[p].x, c.cx.points[p].x);
    EXPECT_EQ(r.values[p], c.values[p]);
    EXPECT_EQ(r.state[p], RepelState::kStill);
  }
  EXPECT_EQ(r.stats.restored, 4u);
  EXPECT_EQ(r.stats.moved, 96u);
  EXPECT_EQ(relax_cells(c.cx, c.values, one, c.sdf, r), 0u);
}

TEST(Repel, SameOnOneThreadAndMany) {
  const Case c = sphere_case(4);
  Repelled one;
  {
    ThreadLimit limit(1);
    one = repel(c.cx, c.cube, c.values, c.sdf);
  }
  const Repelled many = repel(c.cx, c.cube, c.values, c.sdf);
  ASSERT_EQ(one.points.size(), many.points.size());
  for (std::size_t p = 0; p < one.points.size(); ++p) {
    ASSERT_EQ(one.points[p].x, many.points[p].x);
    ASSERT_EQ(one.points[p].y, many.points[p].y);
    ASSERT_EQ(one.points[p].z, many.points[p].z);
    ASSERT_EQ(one.values[p], many.values[p]);
    ASSERT_EQ(one.state[p], many.state[p]);
    ASSERT_EQ(one.off_line[p], many.off_line[p]);
  }
  EXPECT_GT(one.stats.off_line, 0u);
  EXPECT_EQ(one.stats.moved, many.stats.moved);
  EXPECT_EQ(one.stats.rounds, many.stats.rounds);
}

// Every cell relaxed until nothing changes: the first call takes every moved point, the last
// leaves the grid as it was, and every moved point was given back exactly once.
TEST(Repel, RelaxCellsEndAtTheGrid) {
  const Case c = sphere_case(3);
  Repelled r = repel(c.cx, c.cube, c.values, c.sdf);
  std::vector<std::uint32_t> all(c.cx.cells.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  const std::size_t moved = r.stats.moved;
  ASSERT_GT(moved, 0u);
  EXPECT_EQ(relax_cells(c.cx, c.values, all, c.sdf, r), moved);
  for (int call = 0; call < kMaxRelaxHalvings; ++call) relax_cells(c.cx, c.values, all, c.sdf, r);
  EXPECT_EQ(r.stats.moved, 0u);
  EXPECT_EQ(r.stats.restored, moved);
  for (std::size_t p = 0; p < r.points.size(); ++p) {
    EXPECT_EQ(r.points[p].x, c.cx.points[p].x);
    EXPECT_EQ(r.values[p], c.values[p]);
  }
  EXPECT_EQ(relax_cells(c.cx, c.values, all, c.sdf, r), 0u);
}

TEST(Repel, RejectsABadDelta) {
  const Case c = sphere_case(1);
  for (double delta : {0.0, -0.1, 0.46, std::nan("")})
    EXPECT_THROW(repel(c.cx, c.cube, c.values, c.sdf, {delta}), InputError) << delta;
}

}  // namespace
}  // namespace mchex
