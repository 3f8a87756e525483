// Orientation repair (core/mesh/orientation.h): surfaces built here with a known right answer
// (outward spheres and boxes, then damaged: flipped faces, turned inside out, nested, duplicated,
// holed, overlapping), checked with validate_surface as the independent reader of the result,
// and the sample models npm and Debian ship.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/io/surface_io.h"
#include "core/mesh/orientation.h"
#include "core/mesh/surface.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;
using Triangle = std::array<uint32_t, 3>;

// ---------------------------------------------------------------------------------------------
// Shapes, all oriented outward.

// UV sphere: poles and stacks - 1 rings of `slices` vertices.
TriangleSurface sphere(Vec3 centre, double radius, int stacks = 12, int slices = 16) {
  TriangleSurface s;
  const double pi = std::numbers::pi;
  s.vertices.push_back(centre + Vec3{0, 0, radius});
  for (int k = 1; k < stacks; ++k) {
    for (int j = 0; j < slices; ++j) {
      const double phi = pi * k / stacks, theta = 2 * pi * j / slices;
      s.vertices.push_back(
          centre + radius * Vec3{std::sin(phi) * std::cos(theta), std::sin(phi) * std::sin(theta), std::cos(phi)});
    }
  }
  s.vertices.push_back(centre - Vec3{0, 0, radius});
  const auto ring = [&](int k, int j) { return static_cast<uint32_t>(1 + (k - 1) * slices + (j % slices)); };
  const auto south = static_cast<uint32_t>(s.vertices.size() - 1);
  for (int j = 0; j < slices; ++j) s.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
  for (int k = 1; k + 1 < stacks; ++k) {
    for (int j = 0; j < slices; ++j) {
      s.triangles.push_back({ring(k, j), ring(k + 1, j), ring(k + 1, j + 1)});
      s.triangles.push_back({ring(k, j), ring(k + 1, j + 1), ring(k, j + 1)});
    }
  }
  for (int j = 0; j < slices; ++j) s.triangles.push_back({south, ring(stacks - 1, j + 1), ring(stacks - 1, j)});
  return s;
}

// Axis-aligned box; corner i has bit 0 for x, 1 for y, 2 for z; each face split on one diagonal.
TriangleSurface box(Vec3 lo, Vec3 hi) {
  TriangleSurface s;
  for (int i = 0; i < 8; ++i) s.vertices.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const uint32_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    s.triangles.push_back({q[0], q[1], q[2]});
    s.triangles.push_back({q[0], q[2], q[3]});
  }
  return s;
}

TriangleSurface join(std::vector<TriangleSurface> parts) {
  TriangleSurface out;
  for (const auto& p : parts) {
    const auto base = static_cast<uint32_t>(out.vertices.size());
    out.vertices.insert(out.vertices.end(), p.vertices.begin(), p.vertices.end());
    for (auto t : p.triangles) out.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  return out;
}

Triangle flipped(Triangle t) { return {t[0], t[2], t[1]}; }

TriangleSurface inside_out(TriangleSurface s) {
  for (auto& t : s.triangles) t = flipped(t);
  return s;
}

// The triangles as a sorted list, each rotated to start at its smallest index: equal for two
// surfaces with the same oriented faces in any order.
std::vector<Triangle> triangle_set(const TriangleSurface& s) {
  std::vector<Triangle> out;
  for (auto t : s.triangles) {
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    out.push_back(t);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Whether every triangle has the same bits as before (the repair did nothing).
bool same(const TriangleSurface& a, const TriangleSurface& b) {
  return a.triangles == b.triangles && a.vertices.size() == b.vertices.size() &&
         std::equal(a.vertices.begin(), a.vertices.end(), b.vertices.begin());
}

double sphere_volume(double r, int stacks = 12, int slices = 16) {
  return validate_surface(sphere({}, r, stacks, slices)).volume;
}

// ---------------------------------------------------------------------------------------------
// Repairs

TEST(orientation, DescribeSaysWhatWasFoundAndDone) {
  TriangleSurface s = join({sphere({}, 2), inside_out(sphere({}, 1))});
  EXPECT_EQ(describe(repair_orientation(s)),
            "2 components (2 closed, 1 cavity), no boundary, no non-manifold edge, self-intersections: none");
  TriangleSurface t = inside_out(box({}, {1, 1, 1}));
  t.triangles.erase(t.triangles.begin());
  t.triangles.push_back(t.triangles[0]);
  t.triangles.push_back({0, 0, 1});
  t.triangles[2] = flipped(t.triangles[2]);
  EXPECT_EQ(describe(repair_orientation(t)),
            "1 component (0 closed), 3 boundary edges in 1 loop, no non-manifold edge, self-intersections: none; "
            "removed 1 degenerate face, removed 1 duplicate face, flipped 1 triangle");
  TriangleSurface u = box({}, {1, 1, 1});
  u.vertices.insert(u.vertices.end(), {{5, 5, 5}, {6, 5, 5}, {5, 6, 5}});
  u.triangles.insert(u.triangles.end(), {{8, 9, 10}, {8, 10, 9}});
  EXPECT_EQ(describe(repair_orientation(u)),
            "1 component (1 closed), no boundary, no non-manifold edge, self-intersections: none; "
            "removed 2 duplicate faces (1 opposite pair), removed 3 orphaned vertices");
}

TEST(orientation, ConstructedShapesAreOutward) {
  // The oracle for every test below: the shapes as built are closed, consistent and outward.
  for (const auto& s : {sphere({}, 1), box({}, {1, 2, 3})}) {
    const SurfaceReport r = validate_surface(s);
    EXPECT_TRUE(r.consistently_oriented);
    EXPECT_GT(r.volume, 0);
  }
  EXPECT_NEAR(validate_surface(box({}, {1, 2, 3})).volume, 6, 1e-12);
}

TEST(orientation, CleanClosedSurfaceIsUnchangedBitForBit) {
  const TriangleSurface original = join({sphere({}, 1), box({3, 0, 0}, {4, 1, 1})});
  TriangleSurface s = original;
  const OrientationReport r = repair_orientation(s);
  EXPECT_TRUE(same(s, original));
  EXPECT_FALSE(r.changed());
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.closed_components, 2u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.cavities, 0u);
  EXPECT_TRUE(r.nesting_checked);
  EXPECT_TRUE(r.self_intersection_checked);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
}

TEST(orientation, ThirdOfTheFacesFlippedIsRepairedOutward) {
  for (const auto& original : {sphere({}, 1), box({-1, -1, -1}, {1, 1, 1})}) {
    TriangleSurface s = original;
    std::size_t damaged = 0;
    for (std::size_t t = 0; t < s.triangles.size(); t += 3, ++damaged) s.triangles[t] = flipped(s.triangles[t]);
    ASSERT_GT(validate_surface(s).inconsistent_edges, 0u);
    const OrientationReport r = repair_orientation(s);
    EXPECT_EQ(r.flipped_triangles, damaged);  // the minority
    EXPECT_EQ(r.reversed_components, 0u);
    const SurfaceReport v = validate_surface(s);
    EXPECT_TRUE(v.consistently_oriented);
    EXPECT_GT(v.volume, 0);
    EXPECT_TRUE(same(s, original));  // flipping twice restores each triangle's bits
  }
}

TEST(orientation, TwoThirdsFlippedFlipsTheMinorityThenReverses) {
  const TriangleSurface original = sphere({}, 1);
  TriangleSurface s = original;
  std::size_t kept = 0;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    if (t % 3 == 0) {
      ++kept;
    } else {
      s.triangles[t] = flipped(s.triangles[t]);
    }
  }
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.flipped_triangles, kept);
  EXPECT_EQ(r.reversed_components, 1u);
  EXPECT_EQ(r.reversed_triangles, original.triangles.size());
  EXPECT_TRUE(same(s, original));
}

TEST(orientation, InsideOutSurfaceIsReversed) {
  const TriangleSurface original = sphere({5, 5, 5}, 2);
  TriangleSurface s = inside_out(original);
  ASSERT_LT(validate_surface(s).volume, 0);
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.flipped_triangles, 0u);
  EXPECT_EQ(r.reversed_components, 1u);
  EXPECT_EQ(r.cavities, 0u);
  EXPECT_TRUE(same(s, original));
}

TEST(orientation, TwoDisjointSpheresAreBothOutward) {
  const TriangleSurface a = sphere({0, 0, 0}, 1), b = sphere({3, 0, 0}, 1);
  TriangleSurface s = join({a, inside_out(b)});
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.closed_components, 2u);
  EXPECT_EQ(r.reversed_components, 1u);
  EXPECT_EQ(r.cavities, 0u);
  EXPECT_TRUE(same(s, join({a, b})));
  EXPECT_NEAR(validate_surface(s).volume, 2 * sphere_volume(1), 1e-12);
}

TEST(orientation, NestedSphereBecomesACavity) {
  const TriangleSurface outer = sphere({0, 0, 0}, 2), inner = sphere({0.1, 0, 0}, 1);
  for (bool outer_first : {true, false}) {
    // Both given outward (the usual soup); the inner one must face inward.
    TriangleSurface s = outer_first ? join({outer, inner}) : join({inner, outer});
    const OrientationReport r = repair_orientation(s);
    EXPECT_EQ(r.closed_components, 2u);
    EXPECT_EQ(r.cavities, 1u);
    EXPECT_EQ(r.reversed_components, 1u);
    EXPECT_TRUE(same(s, outer_first ? join({outer, inside_out(inner)}) : join({inside_out(inner), outer})));
    EXPECT_NEAR(validate_surface(s).volume, sphere_volume(2) - sphere_volume(1), 1e-12);
  }
  // Already a shell with a cavity: nothing to do.
  TriangleSurface s = join({outer, inside_out(inner)});
  const OrientationReport r = repair_orientation(s);
  EXPECT_FALSE(r.changed());
  EXPECT_EQ(r.cavities, 1u);
}

TEST(orientation, ThreeNestedShellsAlternate) {
  // Depths 0, 1, 2: outward, inward, outward (a solid ball inside a hollow one).
  const TriangleSurface a = sphere({}, 3), b = sphere({}, 2), c = sphere({}, 1);
  TriangleSurface s = join({inside_out(a), c, b});
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.cavities, 1u);
  EXPECT_EQ(r.reversed_components, 2u);
  EXPECT_TRUE(same(s, join({a, c, inside_out(b)})));
}

TEST(orientation, DuplicateAndDegenerateFaces) {
  const TriangleSurface cube = box({}, {1, 1, 1});
  TriangleSurface s = cube;
  const Triangle t0 = s.triangles[0], t1 = s.triangles[1];
  s.triangles.push_back({t0[1], t0[2], t0[0]});  // the same face, rotated: removed
  s.triangles.push_back(t1);                     // two more copies of t1 and one reversed:
  s.triangles.push_back(flipped(t1));            // one pair cancels, the first t1 survives
  s.triangles.push_back(t1);
  s.triangles.push_back({t0[0], t0[0], t0[1]});  // a repeated index
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.degenerate_faces_removed, 1u);
  EXPECT_EQ(r.duplicate_faces_removed, 4u);
  EXPECT_EQ(r.cancelled_pairs, 1u);
  EXPECT_EQ(r.flipped_triangles, 0u);
  EXPECT_TRUE(same(s, cube));
}

TEST(orientation, OppositeDuplicatesCancelAsAZeroThicknessSheet) {
  // A lone opposite pair bounds nothing: both go, leaving a hole with three boundary edges.
  TriangleSurface s = box({}, {1, 1, 1});
  s.triangles.push_back(flipped(s.triangles[4]));
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.cancelled_pairs, 1u);
  EXPECT_EQ(r.duplicate_faces_removed, 2u);
  EXPECT_EQ(s.triangles.size(), 11u);
  EXPECT_EQ(r.boundary_edges, 3u);
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.closed_components, 0u);

  // Two boxes that each bring their copy of the wall between them: the union, one closed box.
  TriangleSurface pair = join({box({0, 0, 0}, {1, 1, 1}), box({1, 0, 0}, {2, 1, 1})});
  weld_vertices(pair);
  const OrientationReport u = repair_orientation(pair);
  EXPECT_EQ(u.cancelled_pairs, 2u);
  EXPECT_EQ(u.components, 1u);
  EXPECT_EQ(u.closed_components, 1u);
  const SurfaceReport v = validate_surface(pair);
  EXPECT_TRUE(v.consistently_oriented);
  EXPECT_NEAR(v.volume, 2, 1e-12);
}

TEST(orientation, VerticesOnlyRemovedFacesUsedGoToo) {
  // A box, a lone opposite pair far away (a sheet that bounds nothing) and an unused vertex.
  const TriangleSurface cube = box({}, {1, 1, 1});
  TriangleSurface s = cube;
  s.vertices.insert(s.vertices.begin() + 4, {{10, 10, 10}, {11, 10, 10}, {10, 11, 10}});
  for (auto& t : s.triangles)
    for (uint32_t& v : t) v += v >= 4 ? 3 : 0;
  s.triangles.insert(s.triangles.begin() + 5, {{4, 5, 6}, {4, 6, 5}});
  s.vertices.push_back({-5, -5, -5});  // used by no face before: stays
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.cancelled_pairs, 1u);
  EXPECT_EQ(r.orphaned_vertices_removed, 3u);
  TriangleSurface expected = cube;
  expected.vertices.push_back({-5, -5, -5});
  EXPECT_TRUE(same(s, expected));
  EXPECT_EQ(s.bounds().hi, (Vec3{1, 1, 1}));
}

TEST(orientation, ZeroAreaFacesAreKeptAndCounted) {
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  s.triangles = {{0, 1, 2}};
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.zero_area_faces, 1u);
  EXPECT_EQ(s.triangles.size(), 1u);
  EXPECT_FALSE(r.changed());
}

TEST(orientation, NothingLeftAfterCleaning) {
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  s.triangles = {{0, 0, 1}, {0, 1, 2}, {0, 2, 1}};  // a repeated index, then an opposite pair
  const OrientationReport r = repair_orientation(s);
  EXPECT_TRUE(s.triangles.empty());
  EXPECT_TRUE(s.vertices.empty());  // only removed faces used them
  EXPECT_EQ(r.orphaned_vertices_removed, 3u);
  EXPECT_EQ(r.degenerate_faces_removed, 1u);
  EXPECT_EQ(r.cancelled_pairs, 1u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_TRUE(r.self_intersection_checked);
  TriangleSurface empty;
  EXPECT_FALSE(repair_orientation(empty).changed());
}

TEST(orientation, SurfaceWithHolesIsMadeConsistent) {
  const TriangleSurface whole = sphere({}, 1);
  TriangleSurface original = whole;
  // Two holes: one north-cap triangle and one band quad far from it.
  const std::size_t band = 16 + 2 * 16 * 5;
  original.triangles.erase(original.triangles.begin() + static_cast<std::ptrdiff_t>(band),
                           original.triangles.begin() + static_cast<std::ptrdiff_t>(band + 2));
  original.triangles.erase(original.triangles.begin() + 3);
  TriangleSurface s = original;
  for (std::size_t t = 1; t < s.triangles.size(); t += 3) s.triangles[t] = flipped(s.triangles[t]);
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.closed_components, 0u);
  EXPECT_EQ(r.boundary_edges, 3u + 4u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.reversed_components, 0u);
  const SurfaceReport v = validate_surface(s);
  EXPECT_EQ(v.inconsistent_edges, 0u);
  EXPECT_EQ(v.boundary_edges, 7u);
  EXPECT_TRUE(same(s, original));  // the majority kept its orientation
}

TEST(orientation, MoebiusBandIsNonOrientable) {
  const int n = 24;
  const double pi = std::numbers::pi;
  TriangleSurface s;
  for (int i = 0; i < n; ++i) {
    const double theta = 2 * pi * i / n, phi = theta / 2;
    for (double w : {0.3, -0.3}) {
      s.vertices.push_back(
          {(2 + w * std::cos(phi)) * std::cos(theta), (2 + w * std::cos(phi)) * std::sin(theta), w * std::sin(phi)});
    }
  }
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t a = 2 * i, b = 2 * i + 1;
    // The last strip joins the first with its sides exchanged: the half twist.
    const uint32_t c = i + 1 < n ? 2 * i + 2 : 1, d = i + 1 < n ? 2 * i + 3 : 0;
    s.triangles.push_back({a, b, c});
    s.triangles.push_back({b, d, c});
  }
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.nonorientable_components, 1u);
  EXPECT_EQ(r.closed_components, 0u);
  EXPECT_EQ(r.boundary_loops, 1u);  // a Moebius band has one boundary circle
  EXPECT_EQ(r.boundary_edges, static_cast<std::size_t>(2 * n));
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
}

TEST(orientation, ShellsTouchingAlongAnEdgeStayClosed) {
  // Two boxes that share only an edge (four triangles on it), the second inside out.
  const TriangleSurface a = box({0, 0, 0}, {1, 1, 1}), b = box({1, 1, 0}, {2, 2, 1});
  TriangleSurface s = join({a, inside_out(b)});
  ASSERT_EQ(weld_vertices(s), 2u);
  TriangleSurface expected = join({a, b});
  weld_vertices(expected);
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.components, 2u);  // the non-manifold edge separates them
  EXPECT_EQ(r.closed_components, 2u);
  EXPECT_EQ(r.reversed_components, 1u);
  EXPECT_TRUE(same(s, expected));
}

TEST(orientation, FinOnAClosedBoxOpensIt) {
  // A third triangle on one of the box's edges: the box uses that edge twice still, the fin once.
  TriangleSurface s = box({0, 0, 0}, {1, 1, 1});
  s.vertices.push_back({0.5, -1, -0.5});
  s.triangles.push_back({0, 1, 8});  // on the edge of corners 0 and 1
  const OrientationReport r = repair_orientation(s);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.closed_components, 1u);
  EXPECT_EQ(r.boundary_edges, 2u);
  EXPECT_EQ(r.boundary_loops, 1u);
}

TEST(orientation, OverlappingShellsSelfIntersect) {
  const TriangleSurface a = sphere({0, 0, 0}, 1), b = sphere({0.8, 0.1, 0.05}, 1);
  TriangleSurface s = join({a, inside_out(b)});
  const OrientationReport r = repair_orientation(s);
  EXPECT_TRUE(r.self_intersection_checked);
  EXPECT_GT(r.self_intersecting_pairs, 0u);
  // Intersecting shells are not nested: both outward, as a union.
  EXPECT_EQ(r.cavities, 0u);
  EXPECT_TRUE(same(s, join({a, b})));

  // A small box poking through the top face of a large one: its vertical edges cross that face.
  TriangleSurface poke = join({box({0, 0, 0}, {4, 4, 4}), box({1.5, 1.7, 3.5}, {2.5, 2.3, 4.5})});
  const OrientationReport p = repair_orientation(poke);
  EXPECT_GT(p.self_intersecting_pairs, 0u);
  EXPECT_EQ(p.cavities, 0u);
}

TEST(orientation, DisjointShellsDoNotSelfIntersect) {
  // Close but apart, and nested: no pair crosses.
  TriangleSurface s = join({sphere({}, 2), sphere({}, 1.9), box({2.01, -1, -1}, {3, 1, 1})});
  const OrientationReport r = repair_orientation(s);
  EXPECT_TRUE(r.self_intersection_checked);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_EQ(r.cavities, 1u);
}

TEST(orientation, PermutedInputGivesTheSameResult) {
  // A soup with every kind of damage, then the same triangles in a shuffled order.
  TriangleSurface holed = sphere({6, 0, 0}, 1);
  holed.triangles.erase(holed.triangles.begin() + 40);
  TriangleSurface soup = join({inside_out(sphere({}, 3)), sphere({0.2, 0, 0}, 2), holed, sphere({0.5, 0.5, 0}, 0.5),
                               sphere({6.5, 0, 0.3}, 0.7)});
  for (std::size_t t = 0; t < soup.triangles.size(); t += 4) soup.triangles[t] = flipped(soup.triangles[t]);
  soup.triangles.push_back(soup.triangles[10]);
  soup.triangles.push_back(flipped(soup.triangles[710]));  // cancels: a second hole in `holed`
  soup.triangles.push_back({1, 1, 2});

  TriangleSurface first = soup;
  const OrientationReport a = repair_orientation(first);
  std::mt19937 rng(12345);
  for (int round = 0; round < 3; ++round) {
    TriangleSurface shuffled = soup;
    for (std::size_t i = shuffled.triangles.size() - 1; i > 0; --i) {
      std::swap(shuffled.triangles[i], shuffled.triangles[rng() % (i + 1)]);
    }
    for (auto& t : shuffled.triangles) std::rotate(t.begin(), t.begin() + rng() % 3, t.end());
    const OrientationReport b = repair_orientation(shuffled);
    EXPECT_EQ(triangle_set(shuffled), triangle_set(first));
    EXPECT_TRUE(b == a) << describe(b) << "\n vs " << describe(a);
  }
  // And what it is: five components, four closed, one cavity (the r = 2 sphere inside r = 3;
  // the r = 0.5 sphere is inside both, so outward), the r = 0.7 sphere crossing the holed one.
  EXPECT_EQ(a.components, 5u);
  EXPECT_EQ(a.closed_components, 4u);
  EXPECT_EQ(a.cavities, 1u);
  EXPECT_EQ(a.degenerate_faces_removed, 1u);
  EXPECT_EQ(a.duplicate_faces_removed, 3u);
  EXPECT_GT(a.self_intersecting_pairs, 0u);
}

TEST(orientation, ThreadCountDoesNotChangeTheResult) {
  TriangleSurface soup =
      join({inside_out(sphere({}, 3, 40, 60)), sphere({0.2, 0, 0}, 2, 40, 60), sphere({2.5, 0, 0}, 1, 40, 60)});
  for (std::size_t t = 0; t < soup.triangles.size(); t += 3) soup.triangles[t] = flipped(soup.triangles[t]);
  TriangleSurface threaded = soup, serial = soup;
  const OrientationReport a = repair_orientation(threaded);
  OrientationReport b;
  {
    ThreadLimit one(1);
    b = repair_orientation(serial);
  }
  EXPECT_TRUE(a == b) << describe(a) << "\n vs " << describe(b);
  EXPECT_TRUE(same(threaded, serial));
  EXPECT_GT(a.self_intersecting_pairs, 0u);  // the r = 1 sphere crosses both others
}

TEST(orientation, StackedTrianglesExceedTheCandidateBudget) {
  // 30000 parallel triangles over one another: every pair is a candidate (4.5e8 pairs), more
  // than the self-intersection test's budget, so it reports that it did not check.
  TriangleSurface s;
  for (uint32_t i = 0; i < 30000; ++i) {
    const double z = 1e-6 * i;
    s.vertices.insert(s.vertices.end(), {{0, 0, z}, {1, 0, z}, {0, 1, z}});
    s.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
  }
  const OrientationReport r = repair_orientation(s);
  EXPECT_FALSE(r.self_intersection_checked);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_EQ(r.components, 30000u);
  EXPECT_FALSE(r.changed());
}

TEST(orientation, ManyShellsSkipNestingAndGoOutward) {
  // 22 x 22 x 21 disjoint tetrahedra: more closed components than the nesting bound allows
  // pairs of, so nesting is not checked; every shell still comes out outward.
  TriangleSurface tet;
  tet.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  std::vector<TriangleSurface> parts;
  for (int i = 0; i < 22 * 22 * 21; ++i) {
    TriangleSurface t = tet;
    for (Vec3& v : t.vertices) v += 2.0 * Vec3{double(i % 22), double(i / 22 % 22), double(i / 484)};
    parts.push_back(i % 7 == 0 ? inside_out(t) : t);
  }
  TriangleSurface s = join(parts);
  const OrientationReport r = repair_orientation(s);
  ASSERT_GT(r.closed_components * r.closed_components, kNestingBudget);
  EXPECT_FALSE(r.nesting_checked);
  EXPECT_EQ(r.reversed_components, (parts.size() + 6) / 7);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  for (uint32_t c = 0; c < parts.size(); ++c) {
    const std::array<uint32_t, 4> piece = {4 * c, 4 * c + 1, 4 * c + 2, 4 * c + 3};
    ASSERT_NEAR(signed_volume(s, piece, s.vertices[4 * c]), 1.0 / 6, 1e-12) << c;
  }
}

TEST(orientation, BadIndexThrowsAndLeavesTheSurface) {
  TriangleSurface s = box({}, {1, 1, 1});
  s.triangles.push_back({0, 1, 99});
  const TriangleSurface before = s;
  EXPECT_THROW(repair_orientation(s), InputError);
  EXPECT_TRUE(same(s, before));
}

TEST(orientation, MillionTriangleSphere) {
  const TriangleSurface original = sphere({1e3, 0, 0}, 1, 501, 1000);
  ASSERT_EQ(original.triangles.size(), 1'000'000u);
  TriangleSurface s = original;
  for (std::size_t t = 0; t < s.triangles.size(); t += 3) s.triangles[t] = flipped(s.triangles[t]);
  const auto start = std::chrono::steady_clock::now();
  const OrientationReport r = repair_orientation(s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RecordProperty("repair_seconds", std::to_string(seconds));
  std::cout << "1M-triangle sphere: " << seconds << " s; " << describe(r) << "\n";
  EXPECT_EQ(r.flipped_triangles, 333'334u);
  EXPECT_TRUE(r.self_intersection_checked);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_TRUE(same(s, original));
  EXPECT_LT(seconds, 30.0);  // generous for a loaded machine
}

TEST(orientation, RepairIsIdempotent) {
  TriangleSurface s = join({inside_out(sphere({}, 3)), sphere({}, 2)});
  for (std::size_t t = 0; t < s.triangles.size(); t += 5) s.triangles[t] = flipped(s.triangles[t]);
  repair_orientation(s);
  const TriangleSurface once = s;
  EXPECT_FALSE(repair_orientation(s).changed());
  EXPECT_TRUE(same(s, once));
}

// ---------------------------------------------------------------------------------------------
// Sample models: what the repair finds on them, and that its result reads as consistent.

// Repairs the file's surface and checks what any repaired surface must satisfy.
OrientationReport repair_file(const fs::path& path) {
  TriangleSurface s = read_surface(path);
  const SurfaceReport before = validate_surface(s);
  const auto start = std::chrono::steady_clock::now();
  const OrientationReport r = repair_orientation(s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const SurfaceReport after = validate_surface(s);
  std::cout << path.filename().string() << " (" << before.triangles << " triangles, " << seconds
            << " s): " << before.inconsistent_edges << " inconsistent edges, volume " << before.volume << " -> "
            << after.volume << "; " << describe(r) << "\n";
  if (r.nonorientable_components == 0) {
    EXPECT_EQ(after.inconsistent_edges, 0u) << path;
  }
  EXPECT_EQ(after.boundary_edges, r.boundary_edges) << path;
  EXPECT_EQ(after.nonmanifold_edges, r.nonmanifold_edges) << path;
  if (after.consistently_oriented && r.cavities == 0) {
    EXPECT_GT(after.volume, 0) << path;
  }
  const TriangleSurface once = s;
  EXPECT_FALSE(repair_orientation(s).changed()) << path;
  EXPECT_TRUE(same(s, once)) << path;
  return r;
}

const fs::path kStlModels = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects";

TEST(orientation_models, Gearwheel) {
  if (!fs::exists(kStlModels / "gearwheel.bin.stl")) GTEST_SKIP() << "npm stl-models not installed";
  const OrientationReport r = repair_file(kStlModels / "gearwheel.bin.stl");
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_GE(r.closed_components, 1u);
}

TEST(orientation_models, Bunny) {
  if (!fs::exists(kStlModels / "bunny.bin.stl")) GTEST_SKIP() << "npm stl-models not installed";
  const OrientationReport r = repair_file(kStlModels / "bunny.bin.stl");
  EXPECT_GT(r.boundary_loops, 0u);  // the bunny is open at the bottom
}

TEST(orientation_models, DebianSamples) {
  std::vector<fs::path> files;
  for (const char* root : {"/usr/share/assimp/models", "/usr/share/openscad"}) {
    if (!fs::exists(root)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(root)) {
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (entry.is_regular_file() && (ext == ".stl" || ext == ".off" || ext == ".obj" || ext == ".ply")) {
        files.push_back(entry.path());
      }
    }
  }
  if (files.empty()) GTEST_SKIP() << "no Debian sample models";
  std::sort(files.begin(), files.end());
  std::size_t repaired = 0;
  for (const auto& path : files) {
    try {
      (void)read_surface(path);
    } catch (const InputError&) {
      continue;  // the broken samples; test_surface covers their messages
    }
    repair_file(path);
    ++repaired;
  }
  RecordProperty("repaired_files", std::to_string(repaired));
}

}  // namespace
}  // namespace mchex
