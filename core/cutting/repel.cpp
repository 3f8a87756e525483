// Grid-point repelling; see repel.h for the rules.
#include "core/cutting/repel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/complex_topology.h"

namespace mchex {
namespace {

// Rounding leaves a met request a few ulps short; such a crossing counts as met.
constexpr double kSlack = 1e-9;

// The zero rule's value (mchex_mesher.h): what the mesher's crossings are computed from.
double zero_rule(double v, double tiny) { return std::abs(v) < tiny ? -tiny : v; }
bool inside_by_zero_rule(double v, double tiny) { return zero_rule(v, tiny) > 0; }

// The points' incident edges, as (other point, edge id), by ascending edge id.
struct Incidence {
  std::vector<std::uint32_t> begin;  // points + 1
  std::vector<std::array<std::uint32_t, 2>> items;
};

Incidence incidence(std::size_t num_points, const ComplexTopology& t) {
  Incidence inc;
  inc.begin.assign(num_points + 1, 0);
  for (const auto& e : t.edge_points) {
    ++inc.begin[e[0] + 1];
    ++inc.begin[e[1] + 1];
  }
  for (std::size_t p = 0; p < num_points; ++p) inc.begin[p + 1] += inc.begin[p];
  inc.items.resize(inc.begin.back());
  std::vector<std::uint32_t> next(inc.begin.begin(), inc.begin.end() - 1);
  for (std::uint32_t id = 0; id < t.edge_points.size(); ++id) {
    const auto& e = t.edge_points[id];
    inc.items[next[e[0]]++] = {e[1], id};
    inc.items[next[e[1]]++] = {e[0], id};
  }
  return inc;
}

struct Request {
  Vec3 dir;           // unit, along the edge's grid line, away from the crossing
  double amount = 0;  // distance that puts the crossing at delta of the edge
  bool any = false;
  bool opposed = false;  // another request points the opposite way
};

struct Repeller {
  const HexComplex& cx;
  const Box& cube;
  const Incidence& inc;
  double delta, tiny, face_tol;
  std::vector<Vec3> dir;      // a moved point's direction (zero until it moves)
  std::vector<double> cap;    // max displacement
  std::vector<double> moved;  // displacement along dir
  std::vector<std::uint8_t> stuck;
  // With RepelOptions::exact_crossings: per edge, the field's zero from edge_points[e][0] at the
  // current positions (NaN on uncut edges); empty for the linear rule.
  std::vector<double> exact;
  const std::vector<std::array<std::uint32_t, 2>>* edge_points = nullptr;

  // Where p's edge `id` to q is crossed, from p, were p's value fp.
  double crossing(std::uint32_t p, std::uint32_t id, double fp, double fq) const {
    if (exact.empty() || std::isnan(exact[id])) return fp / (fp - fq);
    return (*edge_points)[id][0] == p ? exact[id] : 1 - exact[id];
  }

  double rule(double v) const { return zero_rule(v, tiny); }

  Request request(std::uint32_t p, std::span<const Vec3> x, std::span<const double> f) const {
    Request r;
    const double fp = rule(f[p]);
    std::array<Vec3, 64> dirs;  // a complex's points have a handful of edges
    std::size_t num = 0;
    for (std::uint32_t k = inc.begin[p]; k < inc.begin[p + 1]; ++k) {
      const std::uint32_t q = inc.items[k][0];
      const double fq = rule(f[q]);
      if ((fp > 0) == (fq > 0)) continue;
      const double t = crossing(p, inc.items[k][1], fp, fq);
      if (!(t < delta - kSlack)) continue;
      const double amount = (delta - t) * norm(x[q] - x[p]) / (1 - delta);
      const Vec3 d = normalized(cx.points[p] - cx.points[q]);
      if (num < dirs.size()) dirs[num++] = d;
      if (!r.any || amount > r.amount) {  // ties: the lower edge id, met first
        r.dir = d;
        r.amount = amount;
        r.any = true;
      }
    }
    for (std::size_t i = 0; i < num; ++i) r.opposed = r.opposed || dot(dirs[i], r.dir) < -0.5;
    return r;
  }

  // The nearest crossing on p's edges, as a fraction of its edge from p, were p's value fp (the
  // others' as they are): what an off-line move must raise, so that moving away from
  // one crossing never brings another nearer (beside a crease of the field, the gradient of one
  // side can point at the other).
  double nearest_crossing(std::uint32_t p, double fp, std::span<const double> f) const {
    double nearest = 1;
    const double a = rule(fp);
    for (std::uint32_t k = inc.begin[p]; k < inc.begin[p + 1]; ++k) {
      const std::uint32_t q = inc.items[k][0];
      const double b = rule(f[q]);
      if ((a > 0) != (b > 0)) nearest = std::min(nearest, a / (a - b));
    }
    return nearest;
  }
  bool on_face(std::uint32_t p, int axis) const {
    const double o = cx.points[p][axis];
    return std::abs(o - cube.lo[axis]) <= face_tol || std::abs(o - cube.hi[axis]) <= face_tol;
  }
  bool on_cube_face(std::uint32_t p) const { return on_face(p, 0) || on_face(p, 1) || on_face(p, 2); }
  // Whether moving p along d would take it off a face of the padded cube it lies on.
  bool leaves_cube_face(std::uint32_t p, Vec3 d) const {
    for (int i = 0; i < 3; ++i)
      if (on_face(p, i) && std::abs(d[i]) > 1e-12) return true;
    return false;
  }
};

}  // namespace

bool crossing_clear(double t, double delta) { return t >= delta - kSlack && 1 - t >= delta - kSlack; }

Repelled repel(const HexComplex& cx, const Box& cube, std::span<const double> values, const SdfBatch& sdf,
               const RepelOptions& o) {
  if (!(o.delta > 0 && o.delta <= kMaxRepelDelta))
    throw InputError("repel: delta must be in (0, " + std::to_string(kMaxRepelDelta) + "], got " +
                     std::to_string(o.delta));
  if (values.size() != cx.points.size())
    throw InputError("repel: " + std::to_string(values.size()) + " values for " + std::to_string(cx.points.size()) +
                     " grid points");
  const std::size_t n = cx.points.size();
  const ComplexTopology topo = build_topology(cx);
  const Incidence inc = incidence(n, topo);
  Repeller r{cx, cube, inc, o.delta, zero_tolerance_of(cx), 1e-9 * std::max(cube.diagonal(), 1e-300), {}, {},
             {}, {},   {},  nullptr};
  r.dir.assign(n, Vec3{});
  r.moved.assign(n, 0.0);
  r.stuck.assign(n, 0);
  r.cap.assign(n, 0.0);
  parallel_for(n, [&](std::size_t p) {
    double shortest = std::numeric_limits<double>::infinity();
    for (std::uint32_t k = inc.begin[p]; k < inc.begin[p + 1]; ++k)
      shortest = std::min(shortest, norm(cx.points[inc.items[k][0]] - cx.points[p]));
    r.cap[p] = std::isfinite(shortest) ? o.max_move * shortest : 0.0;
  });

  Repelled out;
  out.points = cx.points;
  out.values.assign(values.begin(), values.end());
  // A move kept: p at y, where the field is v. Both kinds of round keep their moves through this
  // and then call end_round, which searches the exact crossings again on the edges of the points
  // the round moved (no other changed); before the first round, all of them.
  std::vector<std::uint32_t> applied, touched;
  auto place = [&](std::uint32_t p, Vec3 y, double v) {
    r.moved[p] = norm(y - cx.points[p]);
    out.points[p] = y;
    out.values[p] = v;
    applied.push_back(p);
  };
  r.edge_points = &topo.edge_points;
  auto end_round = [&] {
    if (o.exact_crossings && r.exact.empty()) {
      r.exact.resize(topo.edge_points.size());
      search_crossings(out.points, topo.edge_points, out.values, r.tiny, sdf, {}, r.exact);
    } else if (o.exact_crossings) {
      touched.clear();
      for (std::uint32_t p : applied)
        for (std::uint32_t k = inc.begin[p]; k < inc.begin[p + 1]; ++k) touched.push_back(inc.items[k][1]);
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      if (!touched.empty()) search_crossings(out.points, topo.edge_points, out.values, r.tiny, sdf, touched, r.exact);
    }
    const bool any = !applied.empty();
    applied.clear();
    return any;
  };
  end_round();
  out.off_line.assign(n, 0);
  out.stats.delta = o.delta;
  const auto positive = [&](double v) { return inside_by_zero_rule(v, r.tiny); };

  std::vector<Vec3> candidate(n);
  std::vector<std::uint8_t> wants(n);
  for (int round = 0; round < o.max_rounds; ++round) {
    // Jacobi: every request from the same positions and values; each point writes its own entry.
    parallel_for(n, [&](std::size_t i) {
      const auto p = static_cast<std::uint32_t>(i);
      wants[p] = 0;
      if (r.stuck[p]) return;
      const Request q = r.request(p, out.points, out.values);
      if (!q.any || q.opposed) return;
      if (r.moved[p] > 0 && dot(q.dir, r.dir[p]) < 1 - 1e-12) return;  // one grid line per point
      if (r.leaves_cube_face(p, q.dir)) {
        r.stuck[p] = 1;
        return;
      }
      const double s = std::min(r.moved[p] + q.amount, r.cap[p]);
      if (!(s > r.moved[p])) {
        r.stuck[p] = 1;
        return;
      }
      candidate[p] = cx.points[p] + s * q.dir;
      r.dir[p] = q.dir;  // read by no other point this round
      wants[p] = 1;
    });
    std::vector<std::uint32_t> movers;
    for (std::uint32_t p = 0; p < n; ++p)
      if (wants[p]) movers.push_back(p);
    if (movers.empty()) break;
    std::vector<Vec3> at(movers.size());
    std::vector<double> v(movers.size());
    for (std::size_t i = 0; i < movers.size(); ++i) at[i] = candidate[movers[i]];
    sdf(at, v);
    for (std::size_t i = 0; i < movers.size(); ++i) {
      const std::uint32_t p = movers[i];
      if (!std::isfinite(v[i]) || positive(v[i]) != positive(values[p])) {
        r.stuck[p] = 1;  // the move would change the point's sign: it stays
        if (r.moved[p] == 0) r.dir[p] = Vec3{};
        continue;
      }
      place(p, at[i], v[i]);
    }
    if (!end_round()) break;
    out.stats.rounds = round + 1;
  }

  // Off the grid lines, for the points still asking (repel.h). Every point's gradient and target
  // come from the same positions and values; the moves are then kept in point order, each against
  // its neighbours' values as they stand (one kept earlier in the round counts), so the result
  // does not depend on the threads.
  for (int round = 0; round < o.off_line_rounds; ++round) {
    parallel_for(n, [&](std::size_t i) {
      const auto p = static_cast<std::uint32_t>(i);
      wants[p] = r.cap[p] > 0 && !r.on_cube_face(p) && r.request(p, out.points, out.values).any;
    });
    std::vector<std::uint32_t> movers;
    for (std::uint32_t p = 0; p < n; ++p)
      if (wants[p]) movers.push_back(p);
    if (movers.empty()) break;
    std::vector<Vec3> probes(6 * movers.size());
    parallel_for(movers.size(), [&](std::size_t i) {
      const std::uint32_t p = movers[i];
      const double h = kGradientStep * r.cap[p];
      for (int a = 0; a < 3; ++a) {
        Vec3 step{};
        step[a] = h;
        probes[6 * i + 2 * a] = out.points[p] + step;
        probes[6 * i + 2 * a + 1] = out.points[p] - step;
      }
    });
    std::vector<double> probe_values(probes.size());
    sdf(probes, probe_values);
    std::vector<Vec3> at(movers.size());
    std::vector<std::uint8_t> aims(movers.size(), 0);
    parallel_for(movers.size(), [&](std::size_t i) {
      const std::uint32_t p = movers[i];
      const double fp = r.rule(out.values[p]);
      const double h = kGradientStep * r.cap[p];
      Vec3 g;
      bool kink = false;
      for (int a = 0; a < 3; ++a) {
        const double ahead = probe_values[6 * i + 2 * a] - out.values[p];
        const double behind = out.values[p] - probe_values[6 * i + 2 * a + 1];
        g[a] = ahead + behind;
        kink = kink || std::abs(ahead - behind) > kKinkSlope * h;
      }
      if (kink || !(norm(g) > 0)) return;  // a crease of the field, or no direction away
      const Vec3 away = normalized(fp > 0 ? g : -1.0 * g);
      double longest = 0;
      for (std::uint32_t k = inc.begin[p]; k < inc.begin[p + 1]; ++k) {
        const std::uint32_t q = inc.items[k][0];
        if ((r.rule(out.values[q]) > 0) != (fp > 0)) longest = std::max(longest, norm(out.points[q] - out.points[p]));
      }
      const double amount = kOffLineMargin * o.delta * longest - std::abs(fp);
      if (!(amount > 0)) return;
      Vec3 y = out.points[p] + amount * away;
      const Vec3 from_grid = y - cx.points[p];
      const double len = norm(from_grid);
      const double off_cap = kOffLineCap * r.cap[p];
      if (len > off_cap) y = cx.points[p] + (off_cap / len) * from_grid;
      at[i] = y;
      aims[i] = 1;
    });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < movers.size(); ++i)
      if (aims[i]) {
        movers[kept] = movers[i];
        at[kept++] = at[i];
      }
    movers.resize(kept);
    at.resize(kept);
    std::vector<double> v(at.size());
    if (!at.empty()) sdf(at, v);
    for (std::size_t i = 0; i < movers.size(); ++i) {
      const std::uint32_t p = movers[i];
      if (!std::isfinite(v[i]) || positive(v[i]) != positive(values[p]) ||
          !(r.nearest_crossing(p, v[i], out.values) > r.nearest_crossing(p, out.values[p], out.values)))
        continue;
      if (!out.off_line[p]) {
        out.off_line[p] = 1;
        out.stats.off_line += 1;
      }
      place(p, at[i], v[i]);
    }
    if (!end_round()) break;
    out.stats.off_line_rounds = round + 1;
  }

  out.halvings.assign(n, 0);
  out.state.assign(n, RepelState::kStill);
  parallel_for(n, [&](std::size_t i) {
    const auto p = static_cast<std::uint32_t>(i);
    if (r.request(p, out.points, out.values).any) out.state[p] = RepelState::kPinned;
    else if (r.moved[p] > 0) out.state[p] = RepelState::kMoved;
  });
  for (std::size_t p = 0; p < n; ++p) {
    out.stats.moved += r.moved[p] > 0;
    out.stats.pinned += out.state[p] == RepelState::kPinned;
  }
  return out;
}

namespace {

bool at_grid_position(const HexComplex& cx, const Repelled& rep, std::uint32_t p) {
  const Vec3 o = cx.points[p];
  return rep.points[p].x == o.x && rep.points[p].y == o.y && rep.points[p].z == o.z;
}

// A moved point given its grid position and value back.
void give_back(const HexComplex& cx, std::span<const double> unmoved_values, std::uint32_t p, Repelled& rep) {
  rep.points[p] = cx.points[p];
  rep.values[p] = unmoved_values[p];
  rep.state[p] = RepelState::kStill;
  rep.stats.moved -= 1;
  rep.stats.restored += 1;
}

}  // namespace

std::size_t relax_cells(const HexComplex& cx, std::span<const double> unmoved_values,
                        std::span<const std::uint32_t> cells, const SdfBatch& sdf, Repelled& rep) {
  if (rep.halvings.size() != cx.points.size()) rep.halvings.assign(cx.points.size(), 0);
  // The moved corners, each once, in ascending order (the result does not depend on the cells'
  // order or on repeats).
  std::vector<std::uint32_t> moved;
  for (std::uint32_t c : cells)
    for (std::uint32_t p : cx.cells.at(c))
      if (!at_grid_position(cx, rep, p)) moved.push_back(p);
  std::sort(moved.begin(), moved.end());
  moved.erase(std::unique(moved.begin(), moved.end()), moved.end());
  const double tiny = zero_tolerance_of(cx);
  const auto positive = [&](double v) { return inside_by_zero_rule(v, tiny); };
  std::vector<std::uint32_t> halve;
  std::vector<Vec3> at;
  for (std::uint32_t p : moved) {
    if (rep.halvings[p] >= kMaxRelaxHalvings) {
      give_back(cx, unmoved_values, p, rep);
      continue;
    }
    halve.push_back(p);
    at.push_back(cx.points[p] + 0.5 * (rep.points[p] - cx.points[p]));
  }
  std::vector<double> v(at.size());
  if (!at.empty()) sdf(at, v);
  for (std::size_t i = 0; i < halve.size(); ++i) {
    const std::uint32_t p = halve[i];
    if (!std::isfinite(v[i]) || positive(v[i]) != positive(unmoved_values[p])) {
      give_back(cx, unmoved_values, p, rep);
      continue;
    }
    rep.points[p] = at[i];
    rep.values[p] = v[i];
    rep.halvings[p] += 1;
    rep.stats.relaxed += 1;
    // Half way back, its crossing is nearer than delta again: a request unmet.
    if (rep.state[p] != RepelState::kPinned) {
      rep.state[p] = RepelState::kPinned;
      rep.stats.pinned += 1;
    }
  }
  return moved.size();
}

}  // namespace mchex
