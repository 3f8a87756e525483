// The junction curves of several regions and the lift of the parity field around them
// (core/pipeline/regions.h crossing_segments, JunctionLift), against curves known exactly: two
// crossing triangles, two boxes whose faces cross along a square, boxes that only touch, and the
// distance to a segment computed here.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/pipeline/regions.h"

namespace mchex {
namespace {

// An outward box, two triangles a face.
TriangleSurface box(Vec3 lo, Vec3 hi) {
  TriangleSurface s;
  for (int i = 0; i < 8; ++i) s.vertices.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const std::array<std::array<uint32_t, 4>, 6> quads = {
      {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};
  for (const auto& q : quads) {
    s.triangles.push_back({q[0], q[1], q[2]});
    s.triangles.push_back({q[0], q[2], q[3]});
  }
  return s;
}

TriangleSurface one_triangle(Vec3 a, Vec3 b, Vec3 c) {
  TriangleSurface s;
  s.vertices = {a, b, c};
  s.triangles = {{0, 1, 2}};
  return s;
}

TEST(CrossingSegments, TwoCrossingTrianglesShareTheOverlapOfTheirCuts) {
  // a lies in z = 0 and covers x in [-1, 2] at y = 0; b stands in y = 0 and crosses z = 0 for x in
  // [0, 1]: they share exactly the segment (0, 0, 0)-(1, 0, 0).
  const TriangleSurface a = one_triangle({-1, -1, 0}, {3, -1, 0}, {-1, 3, 0});
  const TriangleSurface b = one_triangle({0, 0, -1}, {1, 0, -1}, {0.5, 0, 1});
  for (const auto& [p, q] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    const std::vector<Segment> s = crossing_segments(*p, *q);
    ASSERT_EQ(s.size(), 1u);
    const Vec3 lo = s[0][0].x < s[0][1].x ? s[0][0] : s[0][1], hi = s[0][0].x < s[0][1].x ? s[0][1] : s[0][0];
    EXPECT_NEAR(lo.x, 0.25, 1e-15);  // b's edges cross z = 0 at x = 0.25 and 0.75
    EXPECT_NEAR(hi.x, 0.75, 1e-15);
    for (const Vec3& v : s[0]) {
      EXPECT_EQ(v.y, 0.0);
      EXPECT_EQ(v.z, 0.0);
    }
  }
}

TEST(CrossingSegments, TrianglesThatMissTouchOrLieInOnePlaneDoNotCross) {
  const TriangleSurface a = one_triangle({0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  // Above the plane; one corner on it (a touch); an edge on it; coplanar and overlapping.
  for (const TriangleSurface& b :
       {one_triangle({0, 0, 1}, {1, 0, 1}, {0, 1, 2}), one_triangle({0.2, 0.2, 0}, {1, 0, 1}, {0, 1, 1}),
        one_triangle({0, 0, 0}, {1, 0, 0}, {0, 0, 1}), one_triangle({0.1, 0.1, 0}, {2, 0.1, 0}, {0.1, 2, 0})})
    EXPECT_TRUE(crossing_segments(a, b).empty());
  // Beside it: b crosses a's plane, but not a.
  EXPECT_TRUE(crossing_segments(a, one_triangle({2, 2, -1}, {3, 2, -1}, {2, 3, 1})).empty());
}

TEST(CrossingSegments, BoxesCrossAlongTheSquareWhereOnePokesThroughTheOther) {
  // b pokes through a's face x = 2: the junction is the unit square y, z in [0.5, 1.5] on it.
  const TriangleSurface a = box({0, 0, 0}, {2, 2, 2}), b = box({1, 0.5, 0.5}, {3, 1.5, 1.5});
  const std::vector<Segment> s = crossing_segments(a, b);
  ASSERT_FALSE(s.empty());
  double length = 0;
  for (const Segment& g : s) {
    length += norm(g[1] - g[0]);
    for (const Vec3& v : g) {
      EXPECT_EQ(v.x, 2.0);
      // On the square's boundary: one of y and z at 0.5 or 1.5, the other within [0.5, 1.5].
      const bool on_y = v.y == 0.5 || v.y == 1.5, on_z = v.z == 0.5 || v.z == 1.5;
      EXPECT_TRUE((on_y && v.z >= 0.5 && v.z <= 1.5) || (on_z && v.y >= 0.5 && v.y <= 1.5)) << v.y << " " << v.z;
    }
  }
  EXPECT_NEAR(length, 4.0, 1e-12);  // the pieces cover the perimeter once
}

TEST(CrossingSegments, BoxesSharingAFaceOrTouchingAlongAnEdgeHaveNoJunction) {
  EXPECT_TRUE(crossing_segments(box({0, 0, 0}, {1, 1, 1}), box({1, 0, 0}, {2, 1, 1})).empty());
  EXPECT_TRUE(crossing_segments(box({0, 0, 0}, {1, 1, 1}), box({1, 1, 0}, {2, 2, 1})).empty());
  EXPECT_TRUE(crossing_segments(box({0, 0, 0}, {1, 1, 1}), box({2, 0, 0}, {3, 1, 1})).empty());
}

double distance_to(Vec3 p, const Segment& s) {
  // Brute force over 4001 points along the segment (at most 1.25e-4 off for these unit
  // segments): independent of the code under test.
  double best = 1e300;
  for (int i = 0; i <= 4000; ++i) best = std::min(best, norm(p - (s[0] + (i / 4000.0) * (s[1] - s[0]))));
  return best;
}

TEST(JunctionLift, AddsTheLargestRadiusLessDistanceWithinEachSegmentsRadius) {
  // A curve of three segments (an L and a far piece) with radii 0.3, 0.2 and 0.3, points around
  // it; the values are a stand-in parity field: any value of magnitude below the largest radius
  // may be lifted, larger ones never are (no shell is that near, so no curve on one is).
  const std::vector<Segment> curve = {Segment{Vec3{0, 0, 0}, Vec3{1, 0, 0}}, Segment{Vec3{1, 0, 0}, Vec3{1, 1, 0}},
                                      Segment{Vec3{5, 5, 5}, Vec3{5, 5, 6}}};
  const std::vector<double> radii = {0.3, 0.2, 0.3};
  const JunctionLift lift(curve, radii);
  EXPECT_EQ(lift.min_radius(), 0.2);
  EXPECT_EQ(lift.max_radius(), 0.3);
  std::vector<Vec3> points;
  std::vector<double> values;
  for (int i = -4; i <= 14; ++i)
    for (int j = -4; j <= 14; ++j)
      for (int k = -3; k <= 3; ++k) {
        points.push_back({0.0913 * i, 0.0871 * j, 0.1037 * k});
        values.push_back(0.37 * std::sin(double(i * 7 + j * 3 + k)));  // within and beyond 0.3
      }
  std::vector<double> lifted = values;
  const std::size_t changed = lift.lift(points, lifted);
  std::size_t expected_changed = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = 0, margin = 1e300;
    for (std::size_t s = 0; s < curve.size(); ++s) {
      const double d = distance_to(points[i], curve[s]);
      margin = std::min(margin, std::abs(d - radii[s]));
      best = std::max(best, radii[s] - d);
    }
    // Points within the brute force's error of a radius could go either way: left out.
    if (margin < 2e-4) continue;
    const bool lifts = std::abs(values[i]) < 0.3 && best > 0;
    expected_changed += lifts;
    if (lifts) EXPECT_NEAR(lifted[i], values[i] + best, 2e-4) << i;
    else EXPECT_EQ(lifted[i], values[i]) << i;
  }
  EXPECT_GT(expected_changed, 100u);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < points.size(); ++i) differ += lifted[i] != values[i];
  EXPECT_EQ(changed, differ);
  EXPECT_GE(differ, expected_changed);
}

TEST(JunctionLift, NoCurveLiftsNothingAndEveryRadiusIsChecked) {
  const JunctionLift lift({}, {});
  std::vector<Vec3> points = {{0, 0, 0}, {1, 1, 1}};
  std::vector<double> values = {0.0, -0.1};
  EXPECT_EQ(lift.lift(points, values), 0u);
  EXPECT_EQ(values, (std::vector<double>{0.0, -0.1}));
  const std::vector<Segment> one = {Segment{Vec3{0, 0, 0}, Vec3{1, 0, 0}}};
  EXPECT_THROW(JunctionLift(one, {0.0}), std::invalid_argument);
  EXPECT_THROW(JunctionLift(one, {}), std::invalid_argument);
}

}  // namespace
}  // namespace mchex
