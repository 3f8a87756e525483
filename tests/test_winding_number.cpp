// The generalized winding number against independent references: the brute-force definition
// (every triangle), the far field's stated error bound, and solids whose inside is known in
// closed form (a self-intersecting folded spike, flipped faces, holes, overlapping and nested
// shells, each bounded by elementary solid-angle estimates); then the signed distance's
// winding-number sign rule against the pseudonormal one.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "core/base/parallel.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "core/sdf/winding_number.h"

namespace mchex {
namespace {

constexpr double kPi = std::numbers::pi;

// A torus whose tube radius varies as minor * (1 + bump sin(5u) cos(3v)), outward oriented
// (tests/models.py's bumpy_torus).
TriangleSurface bumpy_torus(int nu, int nv) {
  TriangleSurface s;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * kPi * i / nu, v = 2 * kPi * j / nv;
      const double r = 0.4 * (1 + 0.15 * std::sin(5 * u) * std::cos(3 * v));
      s.vertices.push_back({(1 + r * std::cos(v)) * std::cos(u), (1 + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  auto id = [&](int i, int j) { return uint32_t((i % nu) * nv + j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      s.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      s.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return s;
}

// A surface assembled from quads, each oriented away from a point on its inner side; vertices
// with equal coordinates are one vertex, so the pieces share edges.
struct Builder {
  TriangleSurface s;
  std::map<std::tuple<double, double, double>, uint32_t> index;
  uint32_t vertex(Vec3 p) {
    const auto [it, added] = index.try_emplace({p.x, p.y, p.z}, uint32_t(s.vertices.size()));
    if (added) s.vertices.push_back(p);
    return it->second;
  }
  void triangle(Vec3 a, Vec3 b, Vec3 c, Vec3 inner) {
    if (dot(cross(b - a, c - a), (1.0 / 3) * (a + b + c) - inner) < 0) std::swap(b, c);
    s.triangles.push_back({vertex(a), vertex(b), vertex(c)});
  }
  void quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 inner) { triangle(a, b, c, inner), triangle(a, c, d, inner); }
};

// The cube [-1, 1]^3, each face an n x n grid, with a square tube of half-width 0.15 that
// leaves the top face around the z axis, runs up to z = 1.5, across to x = 0.6 and back down
// through the top face to a cap at z = 0.5 (mitred at the bends): a closed, consistently
// oriented but self-intersecting surface. w = 2 in the tube's part inside the cube
// (x in [0.45, 0.75], |y| < 0.15, z in [0.5, 1]), 1 in the rest of the cube and of the tube.
constexpr double kTube = 0.15;
TriangleSurface folded_spike(int n = 8) {
  Builder b;
  auto grid = [&](int axis, double side) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        Vec3 c[4];
        const int di[4] = {0, 1, 1, 0}, dj[4] = {0, 0, 1, 1};
        for (int k = 0; k < 4; ++k) {
          c[k][axis] = side;
          c[k][u] = -1 + 2.0 * (i + di[k]) / n;
          c[k][v] = -1 + 2.0 * (j + dj[k]) / n;
        }
        b.quad(c[0], c[1], c[2], c[3], {});
      }
  };
  if (n % 2) throw std::invalid_argument("folded_spike: n must be even");
  for (int axis = 0; axis < 3; ++axis) grid(axis, -1), grid(axis, 1);
  // The top face's four middle cells ([-h, h]^2) give way to a ring between their outline
  // (corners and edge midpoints, so no edge meets a vertex) and the tube's square.
  const double h = 2.0 / n;
  std::erase_if(b.s.triangles, [&](const auto& t) {
    const Vec3 g = (1.0 / 3) * (b.s.vertices[t[0]] + b.s.vertices[t[1]] + b.s.vertices[t[2]]);
    return g.z > 1 - 1e-12 && std::abs(g.x) < h && std::abs(g.y) < h;
  });
  const Vec3 outer[4] = {{-h, -h, 1}, {h, -h, 1}, {h, h, 1}, {-h, h, 1}};
  const Vec3 inner[4] = {{-kTube, -kTube, 1}, {kTube, -kTube, 1}, {kTube, kTube, 1}, {-kTube, kTube, 1}};
  for (int k = 0; k < 4; ++k) {
    const Vec3 mid = 0.5 * (outer[k] + outer[(k + 1) % 4]);
    b.triangle(outer[k], mid, inner[k], {});
    b.triangle(mid, inner[(k + 1) % 4], inner[k], {});
    b.triangle(mid, outer[(k + 1) % 4], inner[(k + 1) % 4], {});
  }
  // The tube's rings: corner k keeps its y; its other coordinate follows the path (the mitres
  // pair the faces x = -s / top / x = 0.6 + s, and x = +s / bottom / x = 0.6 - s).
  const double s = kTube;
  auto ring = [&](int r, int k) -> Vec3 {
    const double y = inner[k].y, sx = inner[k].x > 0 ? 1 : -1;  // +1: the x = +s side
    switch (r) {
      case 0: return {sx * s, y, 1};
      case 1: return {sx * s, y, 1.5 - sx * s};
      case 2: return {0.6 - sx * s, y, 1.5 - sx * s};
      default: return {0.6 - sx * s, y, 0.5};
    }
  };
  const Vec3 axis_point[3] = {{0, 0, 1.25}, {0.3, 0, 1.5}, {0.6, 0, 1.0}};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k)
      b.quad(ring(r, k), ring(r, (k + 1) % 4), ring(r + 1, (k + 1) % 4), ring(r + 1, k), axis_point[r]);
  b.quad(ring(3, 0), ring(3, 1), ring(3, 2), ring(3, 3), {0.6, 0, 0.6});
  return b.s;
}

double spike_w(Vec3 p) {
  auto in = [&](Vec3 lo, Vec3 hi) {
    return p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
  };
  int w = in({-1, -1, -1}, {1, 1, 1});
  // The tube as three boxes (the mitres' wedges overlap the boxes only near the bends, which the
  // tests keep away from).
  w += in({-kTube, -kTube, 1}, {kTube, kTube, 1.5}) || in({-kTube, -kTube, 1.35}, {0.75, kTube, 1.65}) ||
       in({0.45, -kTube, 0.5}, {0.75, kTube, 1.5});
  return w;
}

// A tessellated sphere moved and scaled; `inward` reverses its triangles.
TriangleSurface sphere(Vec3 centre, double radius, bool inward = false, int segments = 64) {
  TriangleSurface s = tessellate(ShapeKind::kSphere, segments);
  for (Vec3& v : s.vertices) v = centre + radius * v;
  if (inward)
    for (auto& t : s.triangles) std::swap(t[1], t[2]);
  return s;
}

TriangleSurface join(const TriangleSurface& a, const TriangleSurface& b) {
  TriangleSurface s = a;
  const uint32_t o = uint32_t(a.vertices.size());
  s.vertices.insert(s.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) s.triangles.push_back({t[0] + o, t[1] + o, t[2] + o});
  return s;
}

// Points on and around a surface: uniform in its padded box, near its triangles (offsets from
// 1e-4 to 0.1 along random directions), and far away (distances 3 to 100 box sizes).
std::vector<Vec3> sample_points(const TriangleSurface& s, std::size_t per_kind, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const Box box = s.bounds();
  const Vec3 c = box.center(), size = box.size();
  const double diag = box.diagonal();
  auto direction = [&] {
    const double z = 2 * u(rng) - 1, a = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
    return Vec3{r * std::cos(a), r * std::sin(a), z};
  };
  std::vector<Vec3> p;
  for (std::size_t i = 0; i < per_kind; ++i) {
    p.push_back(c + Vec3{(u(rng) - 0.5) * 1.4 * size.x, (u(rng) - 0.5) * 1.4 * size.y, (u(rng) - 0.5) * 1.4 * size.z});
    const auto& t = s.triangles[std::size_t(u(rng) * s.triangles.size()) % s.triangles.size()];
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Vec3 on =
        s.vertices[t[0]] + a * (s.vertices[t[1]] - s.vertices[t[0]]) + b * (s.vertices[t[2]] - s.vertices[t[0]]);
    p.push_back(on + std::pow(10.0, -4 + 3 * u(rng)) * direction());
    p.push_back(c + diag * (3 + 97 * u(rng)) * direction());
  }
  return p;
}

// The fast query's decision equals the definition's (but within rounding of 1/2), and every
// single pass stays within its stated bound of the definition.
void expect_matches_definition(const TriangleSurface& s, const WindingNumber& wn, std::size_t per_kind, unsigned seed) {
  const auto pts = sample_points(s, per_kind, seed);
  std::vector<double> fast(pts.size());
  wn.at(pts, fast);
  int near_half = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double exact = winding_number_exact(s, pts[i]);
    if (std::abs(exact - 0.5) < WindingNumber::kRoundingAllowance) {
      ++near_half;
      continue;
    }
    ASSERT_EQ(fast[i] > 0.5, exact > 0.5) << "point " << i << " exact " << exact << " fast " << fast[i];
    for (double beta : {1.5, 2.0, 4.0}) {
      const auto e = wn.estimate(pts[i], beta);
      ASSERT_LE(std::abs(e.value - exact), e.bound + 1e-10) << "point " << i << " beta " << beta;
    }
  }
  EXPECT_LT(near_half, 5);
}

void expect_matches_definition(const TriangleSurface& s, std::size_t per_kind, unsigned seed) {
  expect_matches_definition(s, WindingNumber(s), per_kind, seed);
}

// Coarse enough that the tree is built over bisected triangles (edges above a 16th of the box's
// diagonal).
TEST(WindingNumber, FastEqualsDefinitionOnBumpyTorus) { expect_matches_definition(bumpy_torus(16, 8), 1200, 1); }
TEST(WindingNumber, FastEqualsDefinitionOnSphere) {
  expect_matches_definition(sphere({0.1, -0.2, 0.3}, 1.3, false, 12), 1200, 2);
}
// Fine enough that nothing is bisected (no edge above a 16th of the diagonal), over a tree of
// its own.
TEST(WindingNumber, FastEqualsDefinitionOnAFinerBumpyTorus) { expect_matches_definition(bumpy_torus(96, 40), 600, 13); }
// Fine enough that nothing is bisected and the tree is the one given (SurfaceSdf shares its own).
TEST(WindingNumber, FastEqualsDefinitionOnAFineBumpyTorusOverAGivenTree) {
  const TriangleSurface s = bumpy_torus(320, 84);
  expect_matches_definition(s, WindingNumber(s, TriangleBvh::build(s)), 300, 12);
}

TEST(WindingNumber, FastEqualsDefinitionOnASoup) {
  // The torus's triangles unwelded, a fifth dropped, a quarter flipped, all jittered: no edge is
  // shared, w takes every value.
  const TriangleSurface torus = bumpy_torus(64, 24);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  TriangleSurface soup;
  for (const auto& t : torus.triangles) {
    if (u(rng) < 0.2) continue;
    const uint32_t o = uint32_t(soup.vertices.size());
    for (uint32_t v : t)
      soup.vertices.push_back(torus.vertices[v] + 0.02 * Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    soup.triangles.push_back(u(rng) < 0.25 ? std::array{o, o + 2, o + 1} : std::array{o, o + 1, o + 2});
  }
  expect_matches_definition(soup, 1200, 4);
}

TEST(WindingNumber, FarFieldOfOnePatchIsWithinItsBound) {
  // A bumpy patch (one tree with a few hundred triangles): at beta just above 1 the whole
  // patch is one far node for points a little beyond its ball, where the expansion is worst.
  TriangleSurface patch;
  const int n = 12;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = double(i) / n - 0.5, y = double(j) / n - 0.5;
      patch.vertices.push_back({x, y, 0.2 * std::sin(5 * x) * std::cos(4 * y)});
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const uint32_t a = i * (n + 1) + j;
      patch.triangles.push_back({a, a + n + 1, a + n + 2});
      patch.triangles.push_back({a, a + n + 2, a + 1});
    }
  const WindingNumber wn(patch);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  double worst_ratio = 0;
  for (int k = 0; k < 4000; ++k) {
    const double z = 2 * u(rng) - 1, a = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
    const Vec3 p = (0.75 + 3 * u(rng)) * Vec3{r * std::cos(a), r * std::sin(a), z};
    const double exact = winding_number_exact(patch, p);
    for (double beta : {1.05, 1.5, 2.0, 3.0}) {
      const auto e = wn.estimate(p, beta);
      ASSERT_LE(std::abs(e.value - exact), e.bound + 1e-12) << "beta " << beta;
      if (e.bound > 1e-9) worst_ratio = std::max(worst_ratio, std::abs(e.value - exact) / e.bound);
    }
  }
  // The bound is not vacuous: somewhere the error comes within a factor 100 of it.
  EXPECT_GT(worst_ratio, 0.01);
}

TEST(WindingNumber, DeterministicOnAnyThreadCount) {
  const TriangleSurface s = bumpy_torus(96, 40);
  const WindingNumber wn(s);
  const auto pts = sample_points(s, 3000, 6);
  std::vector<double> one(pts.size()), all(pts.size());
  {
    ThreadLimit single(1);
    wn.at(pts, one);
  }
  wn.at(pts, all);
  for (std::size_t i = 0; i < pts.size(); ++i)
    ASSERT_EQ(std::bit_cast<uint64_t>(one[i]), std::bit_cast<uint64_t>(all[i]));
  for (std::size_t i = 0; i < pts.size(); i += 97) ASSERT_EQ(wn.at(pts[i]), all[i]);
}

TEST(WindingNumber, PointsOnTheSurfaceAndDegenerateTrianglesTerminate) {
  // At a vertex in the middle of a cube face its own triangles subtend nothing (Van Oosterom &
  // Strackee's atan2(0, 0)) and the rest half a turn: w is 1/2 up to rounding, so no bound
  // decides. Far away, zero-area triangles (no bound to refine). The query still ends, at 1/2.
  TriangleSurface s = folded_spike();
  const uint32_t o = uint32_t(s.vertices.size());
  for (int k = 0; k < 40; ++k) {
    s.vertices.push_back({50.0 + k, 0, 0});
    s.vertices.push_back({50.0 + k, 1, 0});
    s.triangles.push_back({o + 2 * k, o + 2 * k + 1, o + 2 * k});
  }
  const WindingNumber wn(s);
  const Vec3 on_face{-0.25, -1, 0.25};
  EXPECT_NEAR(wn.at(on_face), 0.5, 1e-9);
  EXPECT_NEAR(winding_number_exact(s, on_face), 0.5, 1e-9);
  EXPECT_TRUE(std::isnan(wn.at({std::nan(""), 0, 0})));
  EXPECT_FALSE(wn.inside({INFINITY, 0, 0}));
}

TEST(WindingNumber, EmptySurfaceIsOutsideEverywhere) {
  const WindingNumber wn{TriangleSurface{}};
  EXPECT_EQ(wn.at({0, 0, 0}), 0);
  EXPECT_FALSE(wn.inside({0, 0, 0}));
}

// Random points of the cube region that the tests below keep: away from every face by `gap`.
std::vector<Vec3> spike_points(std::size_t n, double gap, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.8, 1.8);
  std::vector<Vec3> p;
  while (p.size() < n) {
    const Vec3 x{u(rng), u(rng), u(rng)};
    bool near_face = false;
    for (double d : {-1.0, 1.0})
      for (int a = 0; a < 3; ++a) near_face |= std::abs(x[a] - d) < gap;
    for (double d : {-kTube, kTube}) near_face |= std::abs(x.x - d) < gap || std::abs(x.y - d) < gap;
    for (double d : {0.45, 0.75}) near_face |= std::abs(x.x - d) < gap;
    for (double d : {0.5, 1.35, 1.65}) near_face |= std::abs(x.z - d) < gap;
    // Beside the mitred bends the boxes of spike_w are not the tube.
    near_face |= x.z > 1.2 && x.z < 1.8 && std::abs(x.y) < 0.3 && (std::abs(x.x) < 0.3 || std::abs(x.x - 0.6) < 0.3);
    if (!near_face) p.push_back(x);
  }
  return p;
}

TEST(WindingNumber, FoldedSpikeCountsItsOverlapTwice) {
  const TriangleSurface s = folded_spike();
  const SurfaceReport report = validate_surface(s);
  ASSERT_TRUE(report.closed);
  ASSERT_TRUE(report.consistently_oriented);
  const WindingNumber wn(s);
  int twice = 0;
  for (const Vec3& p : spike_points(4000, 0.02, 7)) {
    const double w = spike_w(p);
    twice += w == 2;
    ASSERT_NEAR(winding_number_exact(s, p), w, 1e-9) << p.x << " " << p.y << " " << p.z;
    ASSERT_EQ(wn.inside(p), w > 0);
  }
  EXPECT_GT(twice, 0);
}

TEST(WindingNumber, FlippedThirdKeepsThePointsItCannotReach) {
  // The faces below z = -1/2 flipped (a third of the cube's). For p over the cube's square
  // (|x|, |y| <= 1, z > -1/2), every ray from p meets the flipped part at most once, through the
  // square z = -1/2, so their solid angle is at most area / h^2 = 4 / h^2 (h = z + 1/2): w moves
  // from the clean value by at most 2 / (pi h^2) < 1/2 for z >= 0.7.
  TriangleSurface s = folded_spike();
  const std::size_t cube_faces = 6 * 2 * 8 * 8;
  std::size_t flipped = 0;
  for (auto& t : s.triangles) {
    if ((s.vertices[t[0]].z + s.vertices[t[1]].z + s.vertices[t[2]].z) / 3 < -0.5) std::swap(t[1], t[2]), ++flipped;
  }
  EXPECT_NEAR(double(flipped) / cube_faces, 1.0 / 3, 0.01);
  const WindingNumber wn(s);
  int tested = 0;
  for (const Vec3& p : spike_points(4000, 0.02, 8)) {
    if (p.z < 0.7 || std::abs(p.x) > 0.95 || std::abs(p.y) > 0.95) continue;
    ++tested;
    const double h = p.z + 0.5, w = spike_w(p);
    ASSERT_NEAR(winding_number_exact(s, p), w, 2 / (kPi * h * h)) << p.x << " " << p.y << " " << p.z;
    ASSERT_EQ(wn.inside(p), w > 0) << p.x << " " << p.y << " " << p.z;
  }
  EXPECT_GT(tested, 200);
}

TEST(WindingNumber, HolesChangeWOnlyByWhatTheySubtend) {
  // Two square holes of side 0.5, in the faces x = -1 and y = 1, centred on their faces. A hole
  // of area a in a plane at distance h from p subtends at most a / h^2.
  TriangleSurface s = folded_spike();
  std::erase_if(s.triangles, [&](const auto& t) {
    const Vec3 g = (1.0 / 3) * (s.vertices[t[0]] + s.vertices[t[1]] + s.vertices[t[2]]);
    return (g.x < -1 + 1e-12 && std::abs(g.y) < 0.25 && std::abs(g.z) < 0.25) ||
           (g.y > 1 - 1e-12 && std::abs(g.x) < 0.25 && std::abs(g.z) < 0.25);
  });
  ASSERT_FALSE(validate_surface(s).closed);
  const WindingNumber wn(s);
  int tested = 0;
  for (const Vec3& p : spike_points(4000, 0.02, 9)) {
    const double hx = std::abs(p.x + 1), hy = std::abs(p.y - 1);
    const double moved = (0.25 / (hx * hx) + 0.25 / (hy * hy)) / (4 * kPi);
    if (moved > 0.45) continue;
    ++tested;
    const double w = spike_w(p);
    ASSERT_NEAR(winding_number_exact(s, p), w, moved) << p.x << " " << p.y << " " << p.z;
    ASSERT_EQ(wn.inside(p), w > 0) << p.x << " " << p.y << " " << p.z;
  }
  EXPECT_GT(tested, 2000);
}

// Points away from the spheres' surfaces by more than the tessellation's sag, with their number
// of enclosing balls. Under the parity decision (the multi-region reduction, core/pipeline/regions.h)
// a point is inside where that number is odd, whichever way the shells face.
void expect_shells(const TriangleSurface& s, const std::vector<std::pair<Vec3, double>>& balls, double cavity_sign,
                   WindingNumber::Decision decision = WindingNumber::Decision::kHalf) {
  const WindingNumber wn(s, decision);
  std::mt19937_64 rng(10);
  std::uniform_real_distribution<double> u(-1.6, 1.6);
  int counted[4] = {0, 0, 0, 0};
  for (int k = 0; k < 3000; ++k) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    double w = 0;
    bool near = false;
    for (std::size_t b = 0; b < balls.size(); ++b) {
      const double r = norm(p - balls[b].first);
      near |= std::abs(r - balls[b].second) < 0.01;
      if (r < balls[b].second) w += b == 1 ? cavity_sign : 1;
    }
    if (near) continue;
    ++counted[int(std::abs(w))];
    ASSERT_NEAR(winding_number_exact(s, p), w, 1e-9);
    const bool odd = std::llabs(std::llround(w)) % 2 == 1;
    ASSERT_EQ(wn.inside(p), decision == WindingNumber::Decision::kHalf ? w > 0.5 : odd);
  }
  EXPECT_GT(counted[1], 100);
  EXPECT_GT(counted[0] + counted[2], 100);
  if (balls.size() > 2) {
    EXPECT_GT(counted[3], 30);
  }
}

TEST(WindingNumber, OverlappingShellsCountTwiceInTheirIntersection) {
  expect_shells(join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1)), {{{-0.4, 0, 0}, 1}, {{0.4, 0, 0}, 1}}, 1);
}
TEST(WindingNumber, NestedShellOfTheSameOrientationCountsTwice) {
  expect_shells(join(sphere({}, 1.2), sphere({}, 0.6)), {{{}, 1.2}, {{}, 0.6}}, 1);
}
TEST(WindingNumber, InwardNestedShellIsACavity) {
  expect_shells(join(sphere({}, 1.2), sphere({}, 0.6, true)), {{{}, 1.2}, {{}, 0.6}}, -1);
}
TEST(WindingNumber, ParityIsOddInTheShellsOfOverlapsAndNests) {
  constexpr auto kParity = WindingNumber::Decision::kParity;
  expect_shells(join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1)), {{{-0.4, 0, 0}, 1}, {{0.4, 0, 0}, 1}}, 1,
                kParity);
  expect_shells(join(sphere({}, 1.2), sphere({}, 0.6, true)), {{{}, 1.2}, {{}, 0.6}}, -1, kParity);
  expect_shells(join(join(sphere({}, 1.5), sphere({0.05, 0, 0}, 1)), sphere({0.1, 0, 0}, 0.5)),
                {{{}, 1.5}, {{0.05, 0, 0}, 1}, {{0.1, 0, 0}, 0.5}}, 1, kParity);
}

std::vector<Vec3> grid_points(const Box& box, int n) {
  std::vector<Vec3> p;
  const Vec3 lo = box.lo - 0.1 * box.size(), size = 1.2 * box.size();
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        p.push_back(lo + Vec3{size.x * i / (n - 1), size.y * j / (n - 1), size.z * k / (n - 1)});
  return p;
}

TEST(SurfaceSdfSign, WindingNumberAgreesWithPseudonormalsOnCleanClosedSurfaces) {
  for (const TriangleSurface& s : {bumpy_torus(96, 40), sphere({0.1, 0, 0}, 1)}) {
    const SurfaceSdf pseudo(s), winding(s, SignRule::kWindingNumber);
    EXPECT_EQ(pseudo.sign_rule(), SignRule::kPseudonormal);
    EXPECT_EQ(winding.sign_rule(), SignRule::kWindingNumber);
    const auto pts = grid_points(s.bounds(), 40);
    std::vector<double> a(pts.size()), b(pts.size());
    pseudo.evaluate(pts, a);
    winding.evaluate(pts, b);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      ASSERT_EQ(std::abs(a[i]), std::abs(b[i]));
      if (std::abs(a[i]) > 1e-9) {
        ASSERT_EQ(a[i], b[i]) << "point " << i;
      }
    }
  }
}

TEST(SurfaceSdfSign, WhereTheRulesDifferOnTheFoldedSpikeTheWindingNumberIsRight) {
  const TriangleSurface s = folded_spike();
  const SurfaceSdf pseudo(s), winding(s, SignRule::kWindingNumber);
  const auto pts = spike_points(20000, 0.02, 11);
  std::vector<double> a(pts.size()), b(pts.size());
  pseudo.evaluate(pts, a);
  winding.evaluate(pts, b);
  int differ = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    ASSERT_EQ(std::abs(a[i]), std::abs(b[i]));
    ASSERT_EQ(b[i] > 0, spike_w(pts[i]) > 0) << pts[i].x << " " << pts[i].y << " " << pts[i].z;
    differ += a[i] != b[i];
  }
  EXPECT_GT(differ, 0);
}

TEST(SurfaceSdfSign, WindingNumberIsRightWherePseudonormalsFail) {
  // Two overlapping balls: (0.65, 0, 0) is inside the right one, 0.05 outside the left one's
  // surface, its nearest. The folded spike: (0.8, 0, 0.75) is inside the cube, 0.05 beside the
  // tube that folds back into it, and (0.6, 0, 0.45) 0.05 below the tube's cap.
  const TriangleSurface balls = join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1));
  const TriangleSurface spike = folded_spike();
  for (const auto& [s, p] : {std::pair{&balls, Vec3{0.65, 0, 0}}, std::pair{&spike, Vec3{0.8, 0, 0.75}},
                             std::pair{&spike, Vec3{0.6, 0, 0.45}}}) {
    const SurfaceSdf pseudo(*s), winding(*s, SignRule::kWindingNumber);
    double a = 0, b = 0;
    pseudo.evaluate({&p, 1}, {&a, 1});
    winding.evaluate({&p, 1}, {&b, 1});
    EXPECT_NEAR(std::abs(a), 0.05, 0.002);
    EXPECT_LT(a, 0) << "the pseudonormal of the nearest feature calls it outside";
    EXPECT_EQ(b, -a);
  }
}

TEST(SurfaceSdfSign, ApplyWindingSignMakesAnyBackendsValuesTheWindingNumbers) {
  const TriangleSurface s = join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1));
  const SurfaceSdf pseudo(s), winding(s, SignRule::kWindingNumber);
  auto pts = grid_points(s.bounds(), 30);
  pts.push_back(s.vertices[5]);  // on the surface: 0 either way
  std::vector<double> a(pts.size()), b(pts.size());
  pseudo.evaluate(pts, a);
  winding.evaluate(pts, b);
  apply_winding_sign(WindingNumber(s), pts, a);
  for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(a[i], b[i]) << "point " << i;
  EXPECT_EQ(a.back(), 0);
}

TEST(WindingNumber, ConstantOffSurfaceExactlyOnTwoCycles) {
  // Closed and consistently oriented, shells overlapping, nested or inward included.
  EXPECT_TRUE(WindingNumber(bumpy_torus(24, 12)).constant_off_surface());
  EXPECT_TRUE(WindingNumber(folded_spike()).constant_off_surface());
  EXPECT_TRUE(WindingNumber(join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1))).constant_off_surface());
  EXPECT_TRUE(WindingNumber(join(sphere({}, 1.2), sphere({}, 0.6, true))).constant_off_surface());
  // A degenerate triangle bounds nothing.
  TriangleSurface with_sliver = sphere({}, 1);
  with_sliver.triangles.push_back({0, 0, 1});
  EXPECT_TRUE(WindingNumber(with_sliver).constant_off_surface());
  // A hole, one flipped triangle, a lone triangle, nothing: w is not an integer off the surface.
  TriangleSurface holed = sphere({}, 1), flipped = sphere({}, 1);
  holed.triangles.pop_back();
  std::swap(flipped.triangles[7][1], flipped.triangles[7][2]);
  EXPECT_FALSE(WindingNumber(holed).constant_off_surface());
  EXPECT_FALSE(WindingNumber(flipped).constant_off_surface());
  TriangleSurface lone;
  lone.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  lone.triangles = {{0, 1, 2}};
  EXPECT_FALSE(WindingNumber(lone).constant_off_surface());
  EXPECT_FALSE(WindingNumber(TriangleSurface{}).constant_off_surface());
}

// The ordered re-signing against the point-by-point decision: the same sign everywhere, and on a
// two-cycle most points of a grid decided without a query.
void expect_inherited_signs(const TriangleSurface& s, WindingNumber::Decision decision, bool inherits) {
  const WindingNumber wn(s, decision);
  ASSERT_EQ(wn.constant_off_surface(), inherits);
  const SurfaceSdf sdf(s);
  std::vector<Vec3> pts = grid_points(s.bounds(), 32);
  std::mt19937_64 rng(5);
  const Box box = s.bounds();
  std::uniform_real_distribution<double> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y), uz(box.lo.z, box.hi.z);
  for (int i = 0; i < 4000; ++i) pts.push_back({ux(rng), uy(rng), uz(rng)});
  pts.push_back(s.vertices[3]);  // on the surface: 0
  std::vector<double> d(pts.size());
  sdf.distance(pts, d);
  std::vector<double> v = d;
  const std::size_t queries = apply_winding_sign(wn, pts, morton_order(pts), v);
  std::size_t off_surface = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    off_surface += d[i] != 0;
    ASSERT_EQ(std::abs(v[i]), d[i]);
    if (d[i] != 0) {
      ASSERT_EQ(v[i] > 0, wn.inside(pts[i])) << "point " << i;
    }
  }
  EXPECT_EQ(v.back(), 0);
  if (inherits) {
    EXPECT_LT(queries, off_surface / 3) << "most grid points lie in a neighbour's surface-free ball";
  } else {
    EXPECT_EQ(queries, off_surface);
  }
  // The unordered entry point gives the same values.
  std::vector<double> u = d;
  apply_winding_sign(wn, pts, u);
  EXPECT_EQ(u, v);
}

TEST(SurfaceSdfSign, InheritedSignsAreTheWindingNumbersOwn) {
  constexpr auto kHalf = WindingNumber::Decision::kHalf, kParity = WindingNumber::Decision::kParity;
  expect_inherited_signs(bumpy_torus(96, 40), kHalf, true);
  expect_inherited_signs(folded_spike(), kHalf, true);
  const TriangleSurface balls = join(sphere({-0.4, 0, 0}, 1), sphere({0.4, 0, 0}, 1));
  expect_inherited_signs(balls, kHalf, true);
  expect_inherited_signs(balls, kParity, true);
  expect_inherited_signs(join(sphere({}, 1.2), sphere({}, 0.6, true)), kParity, true);
  TriangleSurface flipped = folded_spike();
  for (auto& t : flipped.triangles) {
    if ((flipped.vertices[t[0]].z + flipped.vertices[t[1]].z + flipped.vertices[t[2]].z) / 3 < -0.5)
      std::swap(t[1], t[2]);
  }
  expect_inherited_signs(flipped, kHalf, false);
}

// Where the octree samples: only the grid points near the surface (within 1.5 grid steps), where
// a point is seldom inside a neighbour's surface-free ball. The signs are still the winding
// number's own, and the rule that lets two overlapping balls decide (and looks back over the
// last points of the curve, not only the previous one) leaves few queries: on this shell of
// the bumpy torus (128,160 points) 10.8 %, against 71 % when a point had to lie in the previous
// point's ball and 41 % with overlapping balls but the previous point only.
TEST(SurfaceSdfSign, NearTheSurfaceOverlappingBallsDecide) {
  const TriangleSurface s = bumpy_torus(96, 40);
  const WindingNumber wn(s);
  ASSERT_TRUE(wn.constant_off_surface());
  const SurfaceSdf sdf(s);
  const Box box = s.bounds();
  constexpr int n = 96;
  const std::vector<Vec3> grid = grid_points(box, n);
  std::vector<double> gd(grid.size());
  sdf.distance(grid, gd);
  const double step = 1.2 * std::max({box.size().x, box.size().y, box.size().z}) / (n - 1);
  std::vector<Vec3> pts;
  std::vector<double> d;
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (gd[i] < 1.5 * step) {
      pts.push_back(grid[i]);
      d.push_back(gd[i]);
    }
  ASSERT_GT(pts.size(), 10000u);
  std::vector<double> v = d;
  const std::size_t queries = apply_winding_sign(wn, pts, morton_order(pts), v);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    ASSERT_EQ(std::abs(v[i]), d[i]);
    if (d[i] != 0) {
      ASSERT_EQ(v[i] > 0, wn.inside(pts[i])) << "point " << i;
    }
  }
  EXPECT_LT(queries, pts.size() / 6) << queries << " of " << pts.size();
}

}  // namespace
}  // namespace mchex
