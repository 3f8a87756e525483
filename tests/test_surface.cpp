// Surface validation, welding and reading: exact expectations on small hand-made surfaces,
// files the tests write in every supported format, the bad inputs a user can hand us, and the
// sample files Debian and npm ship (valid and broken).
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#endif

#include "core/base/error.h"
#include "core/io/surface_io.h"
#include "core/mesh/surface.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Shapes

// Unit cube [0,1]^3, triangles counter-clockwise seen from outside.
TriangleSurface unit_cube(Vec3 offset = {}) {
  TriangleSurface s;
  for (int i = 0; i < 8; ++i) {
    const Vec3 corner{double((i == 1 || i == 2 || i == 5 || i == 6) ? 1 : 0),
                      double((i == 2 || i == 3 || i == 6 || i == 7) ? 1 : 0), double(i >= 4 ? 1 : 0)};
    s.vertices.push_back(corner + offset);
  }
  s.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                 {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
  return s;
}

// Every triangle with its own three vertices, as STL stores them.
TriangleSurface soup(const TriangleSurface& s) {
  TriangleSurface out;
  for (const auto& t : s.triangles) {
    const auto base = static_cast<uint32_t>(out.vertices.size());
    for (uint32_t v : t) out.vertices.push_back(s.vertices[v]);
    out.triangles.push_back({base, base + 1, base + 2});
  }
  return out;
}

TriangleSurface merged(const TriangleSurface& a, const TriangleSurface& b) {
  TriangleSurface out = a;
  const auto base = static_cast<uint32_t>(a.vertices.size());
  out.vertices.insert(out.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) out.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  return out;
}

// A torus as an n x m grid of quads, two triangles each, outward oriented.
TriangleSurface torus(uint32_t n, uint32_t m, double major = 3, double minor = 1) {
  TriangleSurface s;
  const double two_pi = 2 * std::acos(-1.0);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = 0; j < m; ++j) {
      const double u = two_pi * i / n, v = two_pi * j / m;
      s.vertices.push_back({(major + minor * std::cos(v)) * std::cos(u), (major + minor * std::cos(v)) * std::sin(u),
                            minor * std::sin(v)});
    }
  }
  const auto at = [&](uint32_t i, uint32_t j) { return (i % n) * m + (j % m); };
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = 0; j < m; ++j) {
      s.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      s.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// Validation

TEST(surface_validate, UnitCubeIsClosedAndConsistentlyOriented) {
  const SurfaceReport r = validate_surface(unit_cube());
  EXPECT_EQ(r.vertices, 8u);
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.welded_vertices, 0u);
  EXPECT_EQ(r.edges, 18u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.degenerate_faces, 0u);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 1.0);
}

TEST(surface_validate, BoundsOfTheCube) {
  const Box box = unit_cube({-2, 3, 0.5}).bounds();
  EXPECT_EQ(box.lo, (Vec3{-2, 3, 0.5}));
  EXPECT_EQ(box.hi, (Vec3{-1, 4, 1.5}));
  EXPECT_TRUE(TriangleSurface{}.bounds().empty());
}

TEST(surface_validate, VolumeIsExactFarFromTheOrigin) {
  const SurfaceReport r = validate_surface(unit_cube({1e6, -1e6, 1e6}));
  EXPECT_EQ(r.volume, 1.0);
}

TEST(surface_validate, InwardNormalsGiveNegativeVolumeButStayConsistent) {
  TriangleSurface s = unit_cube();
  for (auto& t : s.triangles) std::swap(t[1], t[2]);
  const SurfaceReport r = validate_surface(s);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, -1.0);
}

TEST(surface_validate, CubeWithOneFaceRemovedHasFourBoundaryEdges) {
  TriangleSurface s = unit_cube();
  s.triangles.erase(s.triangles.begin() + 2, s.triangles.begin() + 4);  // the top
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.triangles, 10u);
  EXPECT_EQ(r.edges, 17u);
  EXPECT_EQ(r.boundary_edges, 4u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.consistently_oriented);
}

TEST(surface_validate, FlippedTriangleGivesThreeInconsistentEdges) {
  TriangleSurface s = unit_cube();
  std::swap(s.triangles[5][1], s.triangles[5][2]);
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.inconsistent_edges, 3u);
  EXPECT_TRUE(r.closed);
  EXPECT_FALSE(r.consistently_oriented);
}

TEST(surface_validate, ThreeTrianglesOnOneEdgeAreNonManifold) {
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  s.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.edges, 7u);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_FALSE(r.closed);
}

TEST(surface_validate, TwoDisjointCubesAreTwoComponents) {
  const SurfaceReport r = validate_surface(merged(unit_cube(), unit_cube({3, 0, 0})));
  EXPECT_EQ(r.components, 2u);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 2.0);
}

TEST(surface_validate, CubesSharingOnlyAVertexAreTwoComponents) {
  TriangleSurface s = merged(unit_cube(), unit_cube({1, 1, 1}));
  // Make the second cube's corner 0 the first cube's corner 6, so they touch at one vertex.
  for (auto& t : s.triangles) {
    for (auto& v : t) v = v == 8 ? 6 : v;
  }
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.components, 2u);
  EXPECT_TRUE(r.closed);
}

TEST(surface_validate, DegenerateFaces) {
  TriangleSurface s = unit_cube();
  s.vertices.push_back({0.5, 0, 0});  // 8: on the edge 0-1
  s.triangles.push_back({0, 0, 1});   // repeated index
  s.triangles.push_back({0, 8, 1});   // zero area, distinct indices
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.degenerate_faces, 2u);
  // The repeated-index triangle adds no edges; the collinear one adds 0-8 and 8-1 (boundary)
  // and a third use of 0-1.
  EXPECT_EQ(r.edges, 20u);
  EXPECT_EQ(r.boundary_edges, 2u);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.volume, 1.0);
}

TEST(surface_validate, CollapsedSliverKeepsTheSurfaceClosed) {
  TriangleSurface s = unit_cube();
  s.triangles.push_back({0, 1, 1});
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.degenerate_faces, 1u);
  EXPECT_EQ(r.edges, 18u);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.components, 1u);  // joined to the cube through its distinct vertices
}

TEST(surface_validate, EmptySurfaceIsNotClosed) {
  const SurfaceReport r = validate_surface(TriangleSurface{});
  EXPECT_EQ(r.edges, 0u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 0.0);
}

TEST(surface_validate, WeldedCountIsCopiedIntoTheReport) {
  EXPECT_EQ(validate_surface(unit_cube(), 28).welded_vertices, 28u);
}

TEST(surface_validate, IndexOutOfRangeThrows) {
  TriangleSurface s = unit_cube();
  s.triangles.push_back({0, 1, 8});
  EXPECT_THROW(validate_surface(s), InputError);
  EXPECT_THROW(weld_vertices(s), InputError);
}

TEST(surface_validate, MillionTriangleTorus) {
  const TriangleSurface s = torus(710, 710);
  ASSERT_GE(s.triangles.size(), 1'000'000u);
  const auto start = std::chrono::steady_clock::now();
  const SurfaceReport r = validate_surface(s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RecordProperty("validate_seconds", std::to_string(seconds));
  EXPECT_EQ(r.edges, 3 * s.triangles.size() / 2);
  EXPECT_EQ(static_cast<long long>(r.vertices) - static_cast<long long>(r.edges) + static_cast<long long>(r.triangles),
            0);  // genus 1
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.components, 1u);
  const double exact = 2 * std::pow(std::acos(-1.0), 2) * 3 * 1;
  EXPECT_NEAR(r.volume, exact, 1e-3 * exact);  // the polyhedron is slightly inside the torus
  EXPECT_LT(r.volume, exact);
  EXPECT_LT(seconds, 5.0);  // about 0.1 s on a desktop; generous for slow CI
}

// ---------------------------------------------------------------------------------------------
// Welding

TEST(surface_weld, SoupOfTheCubeWeldsBackToEightVertices) {
  TriangleSurface s = soup(unit_cube());
  ASSERT_EQ(s.vertices.size(), 36u);
  EXPECT_EQ(weld_vertices(s), 28u);
  EXPECT_EQ(s.vertices.size(), 8u);
  const SurfaceReport r = validate_surface(s);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 1.0);
}

TEST(surface_weld, FirstOccurrenceOrderIsKept) {
  TriangleSurface s;
  s.vertices = {{5, 0, 0}, {1, 0, 0}, {5, 0, 0}, {2, 0, 0}, {1, 0, 0}, {0, 7, 0}};
  s.triangles = {{0, 1, 3}, {2, 4, 5}};
  EXPECT_EQ(weld_vertices(s), 2u);
  EXPECT_EQ(s.vertices, (std::vector<Vec3>{{5, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 7, 0}}));
  EXPECT_EQ(s.triangles, (std::vector<std::array<uint32_t, 3>>{{0, 1, 2}, {0, 1, 3}}));
}

TEST(surface_weld, PlusAndMinusZeroAreTheSamePosition) {
  TriangleSurface s;
  s.vertices = {{-0.0, 1, 0}, {0.0, 1, 0}, {0, -0.0, 3}, {0, 0, 3}};
  s.triangles = {{0, 2, 1}, {1, 3, 0}};
  EXPECT_EQ(weld_vertices(s), 2u);
  ASSERT_EQ(s.vertices.size(), 2u);
  EXPECT_TRUE(std::signbit(s.vertices[0].x));  // the first occurrence's value survives
}

TEST(surface_weld, OnlyBitIdenticalCoordinatesMerge) {
  TriangleSurface s;
  const double next = std::nextafter(1.0, 2.0);
  s.vertices = {{1, 1, 1}, {next, 1, 1}, {1, next, 1}, {1, 1, next}};
  s.triangles = {{0, 1, 2}, {0, 2, 3}};
  const TriangleSurface before = s;
  EXPECT_EQ(weld_vertices(s), 0u);
  EXPECT_EQ(s.vertices, before.vertices);
  EXPECT_EQ(s.triangles, before.triangles);
}

TEST(surface_weld, MillionTriangleSoupIsDeterministic) {
  const TriangleSurface indexed = torus(710, 710);
  TriangleSurface a = soup(indexed), b = soup(indexed);
  EXPECT_EQ(weld_vertices(a), a.triangles.size() * 3 - indexed.vertices.size());
  weld_vertices(b);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_TRUE(validate_surface(a).consistently_oriented);
}

// ---------------------------------------------------------------------------------------------
// Files written by the tests

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    static int counter = 0;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("mchex_test_surface_" + std::to_string(static_cast<long long>(::getpid())) +
                                        "_" + std::to_string(counter++) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& bytes) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  fs::path dir_;
};

// Suite names carry "surface" so that `ctest -R surface` selects them.
using surface_read = TempDir;
using surface_bad_input = TempDir;

std::string le32(uint32_t x) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((x >> (8 * i)) & 0xff);
  return s;
}
std::string lef(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  return le32(bits);
}

std::string number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", x);
  return buffer;
}

std::string binary_stl(const TriangleSurface& s, std::string header = "binary STL written by test_surface") {
  header.resize(80, '\0');
  std::string out = header + le32(static_cast<uint32_t>(s.triangles.size()));
  for (const auto& t : s.triangles) {
    out += lef(0) + lef(0) + lef(0);
    for (uint32_t v : t) out += lef(float(s.vertices[v].x)) + lef(float(s.vertices[v].y)) + lef(float(s.vertices[v].z));
    out += std::string(2, '\0');
  }
  return out;
}

std::string ascii_stl(const TriangleSurface& s) {
  std::string out = "solid test\n";
  for (const auto& t : s.triangles) {
    out += "  facet normal 0 0 0\n    outer loop\n";
    for (uint32_t v : t)
      out += "      vertex " + number(s.vertices[v].x) + " " + number(s.vertices[v].y) + " " + number(s.vertices[v].z) +
             "\n";
    out += "    endloop\n  endfacet\n";
  }
  return out + "endsolid test\n";
}

std::string obj(const TriangleSurface& s) {
  std::string out = "# written by test_surface\n";
  for (const Vec3& v : s.vertices) out += "v " + number(v.x) + " " + number(v.y) + " " + number(v.z) + "\n";
  for (const auto& t : s.triangles)
    out += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) + "\n";
  return out;
}

std::string off(const TriangleSurface& s) {
  std::string out = "OFF\n" + std::to_string(s.vertices.size()) + " " + std::to_string(s.triangles.size()) + " 0\n";
  for (const Vec3& v : s.vertices) out += number(v.x) + " " + number(v.y) + " " + number(v.z) + "\n";
  for (const auto& t : s.triangles)
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  return out;
}

std::string ply_header(const TriangleSurface& s, const char* format) {
  return std::string("ply\nformat ") + format + " 1.0\ncomment written by test_surface\nelement vertex " +
         std::to_string(s.vertices.size()) + "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(s.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string ascii_ply(const TriangleSurface& s) {
  std::string out = ply_header(s, "ascii");
  for (const Vec3& v : s.vertices) out += number(v.x) + " " + number(v.y) + " " + number(v.z) + "\n";
  for (const auto& t : s.triangles)
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  return out;
}

std::string binary_ply(const TriangleSurface& s) {
  std::string out = ply_header(s, "binary_little_endian");
  for (const Vec3& v : s.vertices) out += lef(float(v.x)) + lef(float(v.y)) + lef(float(v.z));
  for (const auto& t : s.triangles) out += std::string(1, '\3') + le32(t[0]) + le32(t[1]) + le32(t[2]);
  return out;
}

struct Writer {
  const char* name;
  const char* extension;
  std::function<std::string(const TriangleSurface&)> write;
  std::size_t cube_welds;  // how many vertices the reader merges for the unit cube
};

const std::vector<Writer>& writers() {
  static const std::vector<Writer> all = {
      {"binary_stl", ".stl", [](const TriangleSurface& s) { return binary_stl(s); }, 28},
      {"ascii_stl", ".stl", ascii_stl, 28},
      {"obj", ".obj", obj, 0},
      {"off", ".off", off, 0},
      {"ascii_ply", ".ply", ascii_ply, 0},
      {"binary_ply", ".ply", binary_ply, 0},
  };
  return all;
}

TEST_F(surface_read, UnitCubeInEveryFormat) {
  for (const Writer& writer : writers()) {
    SCOPED_TRACE(writer.name);
    const fs::path path = write(std::string("cube_") + writer.name + writer.extension, writer.write(unit_cube()));
    std::size_t welded = 99;
    const TriangleSurface s = read_surface(path, &welded);
    EXPECT_EQ(welded, writer.cube_welds);
    const SurfaceReport r = validate_surface(s, welded);
    EXPECT_EQ(r.vertices, 8u);
    EXPECT_EQ(r.triangles, 12u);
    EXPECT_EQ(r.edges, 18u);
    EXPECT_TRUE(r.closed);
    EXPECT_TRUE(r.consistently_oriented);
    EXPECT_EQ(r.volume, 1.0);
    EXPECT_EQ(r.welded_vertices, writer.cube_welds);
    EXPECT_EQ(s.bounds().lo, (Vec3{0, 0, 0}));
    EXPECT_EQ(s.bounds().hi, (Vec3{1, 1, 1}));
  }
}

TEST_F(surface_read, TwoCubesInEveryFormatKeepTheirComponentsAndOrder) {
  const TriangleSurface two = merged(unit_cube(), unit_cube({2, 0, 0}));
  for (const Writer& writer : writers()) {
    SCOPED_TRACE(writer.name);
    const TriangleSurface s =
        read_surface(write(std::string("two_") + writer.name + writer.extension, writer.write(two)));
    const SurfaceReport r = validate_surface(s);
    EXPECT_EQ(r.components, 2u);
    EXPECT_EQ(r.volume, 2.0);
    // Vertices come in order of first use, so the same surface reads the same in every format.
    EXPECT_EQ(s.vertices.front(), (Vec3{0, 0, 0}));
    EXPECT_EQ(s.triangles.front(), (std::array<uint32_t, 3>{0, 1, 2}));
  }
}

// Random surfaces, written and read back: catches a reader that silently shifts or drops data
// for some byte patterns (Assimp reads one binary PLY in 256 out of step on its own).
TEST_F(surface_read, RandomSurfacesRoundTripInEveryFormat) {
  std::mt19937 random(2024);
  std::uniform_real_distribution<float> coordinate(-100, 100);
  for (int sample = 0; sample < 40; ++sample) {
    TriangleSurface original;
    const uint32_t vertices = 4 + random() % 60;
    for (uint32_t v = 0; v < vertices; ++v) {
      original.vertices.push_back({coordinate(random), coordinate(random), coordinate(random)});
    }
    const uint32_t triangles = 1 + random() % 100;
    while (original.triangles.size() < triangles) {
      const std::array<uint32_t, 3> t{uint32_t(random() % vertices), uint32_t(random() % vertices),
                                      uint32_t(random() % vertices)};
      if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) original.triangles.push_back(t);
    }
    // What the reader returns: the vertices in order of first use.
    TriangleSurface expected;
    std::vector<uint32_t> remap(vertices, UINT32_MAX);
    for (const auto& t : original.triangles) {
      std::array<uint32_t, 3> mapped{};
      for (int k = 0; k < 3; ++k) {
        if (remap[t[k]] == UINT32_MAX) {
          remap[t[k]] = static_cast<uint32_t>(expected.vertices.size());
          expected.vertices.push_back(original.vertices[t[k]]);
        }
        mapped[k] = remap[t[k]];
      }
      expected.triangles.push_back(mapped);
    }
    for (const Writer& writer : writers()) {
      SCOPED_TRACE(std::string(writer.name) + " sample " + std::to_string(sample));
      const TriangleSurface s =
          read_surface(write(std::string("random_") + writer.name + writer.extension, writer.write(original)));
      ASSERT_EQ(s.triangles, expected.triangles);
      ASSERT_EQ(s.vertices.size(), expected.vertices.size());
      const bool binary = std::string(writer.name).starts_with("binary");
      for (std::size_t v = 0; v < s.vertices.size(); ++v) {
        for (int axis = 0; axis < 3; ++axis) {
          const double got = s.vertices[v][axis], want = expected.vertices[v][axis];
          // Assimp's text number parser is not correctly rounded: allow one float step.
          const double ulp = std::abs(want) * std::numeric_limits<float>::epsilon();
          if (binary) {
            ASSERT_EQ(got, want) << "vertex " << v;
          } else {
            ASSERT_LE(std::abs(got - want), ulp) << "vertex " << v;
          }
        }
      }
    }
  }
}

TEST_F(surface_read, WeldCountsTheFilesOwnDuplicates) {
  // Assimp gives every OBJ face corner its own vertex; the count must still be the file's.
  TriangleSurface cube = unit_cube();
  cube.vertices.push_back(cube.vertices[6]);  // a second record of corner 6, used once
  cube.triangles[2][2] = 8;
  cube.vertices.push_back({5, 5, 5});  // unused: dropped, not welded
  for (const Writer& writer : writers()) {
    SCOPED_TRACE(writer.name);
    std::size_t welded = 99;
    const TriangleSurface s =
        read_surface(write(std::string("duplicate_") + writer.name + writer.extension, writer.write(cube)), &welded);
    EXPECT_EQ(s.vertices.size(), 8u);
    EXPECT_EQ(welded, writer.cube_welds == 0 ? 1u : writer.cube_welds);
    EXPECT_TRUE(validate_surface(s).consistently_oriented);
  }
}

TEST_F(surface_read, ExtensionIsCaseInsensitive) {
  EXPECT_EQ(read_surface(write("CUBE.STL", binary_stl(unit_cube()))).triangles.size(), 12u);
  EXPECT_EQ(read_surface(write("cube.Obj", obj(unit_cube()))).triangles.size(), 12u);
  EXPECT_EQ(read_surface(write("cube.oFF", off(unit_cube()))).triangles.size(), 12u);
  EXPECT_EQ(read_surface(write("cube.PLY", ascii_ply(unit_cube()))).triangles.size(), 12u);
}

TEST_F(surface_read, ObjPolygonsAreTriangulatedAndOtherPrimitivesIgnored) {
  std::string text = "mtllib does_not_exist.mtl\nusemtl missing\n";
  for (const Vec3& v : unit_cube().vertices) text += "v " + number(v.x) + " " + number(v.y) + " " + number(v.z) + "\n";
  text += "vt 0 0\nvn 0 0 1\n";
  // Quads of the cube, with the corner forms OBJ allows and negative (relative) indices.
  text += "f 1/1 4/1 3/1 2/1\nf 5//1 6//1 7//1 8//1\nf 1/1/1 2/1/1 6/1/1 5/1/1\n";
  text += "f -5 -1 -2 -6\nf 1 5 8 4\nf 2 3 7 6\n";
  text += "l 1 7\np 3\n";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const TriangleSurface s = read_surface(write("quads.obj", text));
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  const SurfaceReport r = validate_surface(s);
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.vertices, 8u);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 1.0);
}

TEST_F(surface_read, ObjMaterialStatementsAreIgnored) {
  // Assimp 5.2 alone crashes on this: a texture map statement after an mtllib it cannot open.
  const std::string text = "mtllib missing.mtl\nusemtl red\nmap_Kd red.png\n" + obj(unit_cube());
  const SurfaceReport r = validate_surface(read_surface(write("material.obj", text)));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_TRUE(r.consistently_oriented);
}

TEST_F(surface_read, ObjNumbersStartingWithTheDecimalPoint) {
  // Assimp 5.2 alone drops such a vertex and then finds the faces out of range.
  const std::string text = "v 0 0 0\nv .5 0 0\nv 0 .25 0\nv 0 0 -.125\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  const TriangleSurface s = read_surface(write("decimal_point.obj", text));
  EXPECT_EQ(s.vertices, (std::vector<Vec3>{{0, 0, 0}, {0, 0.25, 0}, {0.5, 0, 0}, {0, 0, -0.125}}));
  EXPECT_TRUE(validate_surface(s).consistently_oriented);
}

TEST_F(surface_read, BinaryStlHeaderThatLooksLikeAByteOrderMark) {
  // Assimp converts such a file to UTF-8 before checking its size; the header is free text.
  for (const std::string& mark :
       std::vector<std::string>{"\xEF\xBB\xBF", "\xFE\xFF", "\xFF\xFE", std::string("\0\0\xFE\xFF", 4)}) {
    const SurfaceReport r = validate_surface(read_surface(write("bom.stl", binary_stl(unit_cube(), mark + "cube"))));
    EXPECT_EQ(r.triangles, 12u);
    EXPECT_EQ(r.volume, 1.0);
  }
}

TEST_F(surface_read, ObjFacesMayComeBeforeTheirVertices) {
  std::string text = obj(unit_cube());
  const std::size_t faces = text.find("\nf ") + 1;
  text = text.substr(faces) + text.substr(0, faces);
  const SurfaceReport r = validate_surface(read_surface(write("faces_first.obj", text)));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.volume, 1.0);
}

TEST_F(surface_read, OffPolygonsAndVariants) {
  // COFF with colours, a comment in the header, CRLF line ends, quads, a face colour.
  std::string text = "COFF # coloured\r\n# counts follow\r\n8 6 12\r\n\r\n";
  for (const Vec3& v : unit_cube().vertices)
    text += number(v.x) + " " + number(v.y) + " " + number(v.z) + " 0.5 0.5 0.5 1\r\n";
  text += "4 0 3 2 1\r\n4 4 5 6 7 255 0 0\r\n4 0 1 5 4\r\n4 3 7 6 2\r\n4 0 4 7 3\r\n4 1 2 6 5\r\n";
  const SurfaceReport r = validate_surface(read_surface(write("cube.off", text)));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume, 1.0);
}

TEST_F(surface_read, BinaryStlWhoseHeaderStartsWithSolid) {
  const SurfaceReport r =
      validate_surface(read_surface(write("solid_header.stl", binary_stl(unit_cube(), "solid cube"))));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.volume, 1.0);
}

TEST_F(surface_read, AsciiStlWithSeveralSolidsAndLeadingBlankLines) {
  TriangleSurface half_a = unit_cube(), half_b = unit_cube();
  half_a.triangles.resize(6);
  half_b.triangles.erase(half_b.triangles.begin(), half_b.triangles.begin() + 6);
  const std::string text = "\n  \r\n" + ascii_stl(half_a) + ascii_stl(half_b);
  const SurfaceReport r = validate_surface(read_surface(write("two_solids.stl", text)));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_TRUE(r.consistently_oriented);
}

TEST_F(surface_read, AsciiStlThatLooksBinaryToA32BitSizeCheck) {
  // A valid ascii file whose bytes 80..83, read as a facet count n, make 84 + 50 n wrap to the
  // file size in 32 bits: Assimp alone would parse it as binary. The long solid name puts the
  // chosen n at bytes 80..83; trailing blank lines give the size.
  const std::string body = ascii_stl(unit_cube()).substr(std::string("solid test\n").size());
  const std::size_t base = 84 + 1 + body.size();  // "solid " + name (78) + "\n" + body
  std::string text;
  for (uint64_t wraps = 1; wraps < 50 && text.empty(); ++wraps) {
    for (uint64_t size = base; size < base + 200 && text.empty(); ++size) {
      if ((wraps * (uint64_t{1} << 32) + size - 84) % 50 != 0) continue;
      const uint64_t n = (wraps * (uint64_t{1} << 32) + size - 84) / 50;
      if (n > 0xffffffffu) continue;
      std::string name(74, 'x');
      bool printable = true;
      for (int i = 0; i < 4; ++i) {
        const auto byte = static_cast<unsigned char>((n >> (8 * i)) & 0xff);
        printable = printable && byte > 0x20 && byte < 0x7f;
        name += static_cast<char>(byte);
      }
      if (!printable) continue;
      text = "solid " + name + "\n" + body + std::string(size - base, '\n');
    }
  }
  ASSERT_FALSE(text.empty());
  uint32_t n = 0;
  std::memcpy(&n, text.data() + 80, 4);
  ASSERT_EQ(static_cast<uint32_t>(84u + 50u * n), static_cast<uint32_t>(text.size()));
  const SurfaceReport r = validate_surface(read_surface(write("wraps.stl", text)));
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.volume, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Bad input: every failure is an InputError "PATH: reason" on one line, and nothing is printed.

std::string expect_input_error(const fs::path& path, const std::string& reason_part) {
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  std::string message;
  try {
    read_surface(path);
    ADD_FAILURE() << path << " was accepted";
  } catch (const InputError& e) {
    message = e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << " threw a non-InputError: " << e.what();
  }
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "") << path;
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << path;
  if (message.empty()) return message;
  EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
  EXPECT_GT(message.size(), path.string().size() + 2) << "no reason given";
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_EQ(message.find('\r'), std::string::npos) << message;
  EXPECT_NE(message.find(reason_part), std::string::npos)
      << "reason should mention '" << reason_part << "': " << message;
  return message;
}

long peak_rss_kib() {
#if defined(__linux__)
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
#else
  return 0;
#endif
}

// Fails fast and small: a corrupt count must not turn into an allocation or a long loop.
void expect_fast_input_error(const fs::path& path, const std::string& reason_part) {
  const long rss_before = peak_rss_kib();
  const auto start = std::chrono::steady_clock::now();
  expect_input_error(path, reason_part);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 1.0) << path;
  EXPECT_LT(peak_rss_kib() - rss_before, 64 * 1024) << path << ": peak memory grew";
}

TEST_F(surface_bad_input, MissingFile) { expect_input_error(dir_ / "missing.stl", "no such file"); }

TEST_F(surface_bad_input, Directory) {
  fs::create_directory(dir_ / "folder.stl");
  expect_input_error(dir_ / "folder.stl", "is a directory");
}

#if defined(__linux__)
TEST_F(surface_bad_input, FifoIsRefusedWithoutBlocking) {
  const fs::path fifo = dir_ / "pipe.stl";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_fast_input_error(fifo, "not a regular file");
}
#endif

TEST_F(surface_bad_input, EmptyFileInEveryFormat) {
  for (const char* name : {"empty.stl", "empty.obj", "empty.off", "empty.ply"})
    expect_input_error(write(name, ""), "empty");
}

TEST_F(surface_bad_input, UnknownOrMissingExtension) {
  expect_input_error(write("cube.3ds", binary_stl(unit_cube())), "unknown file extension '.3ds'");
  expect_input_error(write("cube", binary_stl(unit_cube())), "no file extension");
}

TEST_F(surface_bad_input, PathWithANewlineStaysOnOneLine) {
  try {
    read_surface(dir_ / "two\nlines.stl");
    ADD_FAILURE() << "a missing file was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message.find("two\\x0alines.stl: no such file"), std::string::npos) << message;
  }
}

TEST_F(surface_bad_input, TruncatedBinaryStl) {
  const std::string full = binary_stl(unit_cube());
  expect_input_error(write("truncated.stl", full.substr(0, full.size() - 30)), "truncated");
  expect_input_error(write("truncated_solid.stl", binary_stl(unit_cube(), "solid cube").substr(0, 300)), "truncated");
  expect_input_error(write("header_only.stl", full.substr(0, 60)), "84-byte header");
  expect_input_error(write("extra.stl", full + "junk"), "truncated or corrupt");
}

TEST_F(surface_bad_input, BinaryStlClaimingTwoBillionFaces) {
  std::string bytes = binary_stl(unit_cube());
  bytes.replace(80, 4, le32(2'000'000'000u));
  expect_fast_input_error(write("two_billion.stl", bytes), "declares 2000000000 triangles");
  // 2^31 + 1 facets make 84 + 50 n wrap to 134 in 32 bits, the size of a one-facet file.
  std::string wrap = binary_stl(unit_cube()).substr(0, 134);
  wrap.replace(80, 4, le32(2'147'483'649u));
  expect_fast_input_error(write("wraps.stl", wrap), "declares 2147483649 triangles");
}

TEST_F(surface_bad_input, NonFiniteCoordinatesInAsciiStl) {
  const std::string cube = ascii_stl(unit_cube());
  const auto with = [&](const std::string& value) {
    std::string text = cube;
    text.replace(text.find("vertex 1 1 1"), 12, "vertex 1 " + value + " 1");
    return text;
  };
  expect_input_error(write("nan.stl", with("nan")), "not finite");
  expect_input_error(write("NaN.stl", with("NaN")), "not finite");
  expect_input_error(write("inf.stl", with("inf")), "not finite");
  expect_input_error(write("minus_inf.stl", with("-Infinity")), "not finite");
  expect_input_error(write("overflow.stl", with("1e400")), "not finite");
  expect_input_error(write("float_overflow.stl", with("1e39")), "beyond single precision");
}

TEST_F(surface_bad_input, NonFiniteCoordinatesInObj) {
  const std::string cube = obj(unit_cube());
  const auto with = [&](const std::string& value) {
    std::string text = cube;
    text.replace(text.find("v 1 1 1"), 7, "v 1 1 " + value);
    return text;
  };
  const std::string message = expect_input_error(write("nan.obj", with("nan")), "not finite");
  EXPECT_NE(message.find("line 8"), std::string::npos) << message;
  expect_input_error(write("inf.obj", with("inf")), "not finite");
  expect_input_error(write("minus_inf.obj", with("-inf")), "not finite");
  expect_input_error(write("overflow.obj", with("-1e999")), "not finite");
}

TEST_F(surface_bad_input, NonFiniteCoordinatesInBinaryFormats) {
  TriangleSurface cube = unit_cube();
  cube.vertices[6].y = std::numeric_limits<double>::quiet_NaN();
  expect_input_error(write("nan.stl", binary_stl(cube)), "non-finite");
  expect_input_error(write("nan.ply", binary_ply(cube)), "non-finite");
  cube.vertices[6].y = std::numeric_limits<double>::infinity();
  expect_input_error(write("inf.stl", binary_stl(cube)), "non-finite");
  expect_input_error(write("inf_ascii.ply", ascii_ply(cube)), "non-finite");
  expect_input_error(write("inf.off", off(cube)), "not finite");
}

TEST_F(surface_bad_input, ObjFaceIndexOutOfRange) {
  const std::string cube = obj(unit_cube());
  std::string message = expect_input_error(write("beyond.obj", cube + "f 1 2 9\n"), "refers to vertex 9");
  EXPECT_NE(message.find("line 22"), std::string::npos) << message;
  expect_input_error(write("relative.obj", cube + "f 1 2 -9\n"), "refers to vertex -9");
  expect_input_error(write("zero.obj", cube + "f 0 1 2\n"), "start at 1");
  expect_input_error(write("huge.obj", cube + "f 1 2 99999999999999999999\n"), "not a face corner");
  expect_input_error(write("word.obj", cube + "f 1 2 three\n"), "not a face corner");
}

TEST_F(surface_bad_input, OffFaceIndexOutOfRange) {
  const std::string cube = off(unit_cube());
  std::string text = cube;
  text.replace(text.rfind("3 1 6 5"), 7, "3 1 6 8");
  const std::string message = expect_input_error(write("beyond.off", text), "refers to vertex 8");
  EXPECT_NE(message.find("line 22"), std::string::npos) << message;
  text = cube;
  text.replace(text.rfind("3 1 6 5"), 7, "3 1 6 -1");
  expect_input_error(write("negative.off", text), "not a vertex index");
}

TEST_F(surface_bad_input, PlyFaceIndexOutOfRange) {
  TriangleSurface cube = unit_cube();
  cube.triangles.back()[2] = 8;
  expect_input_error(write("beyond_ascii.ply", ascii_ply(cube)), "refers to vertex 8");
  expect_input_error(write("beyond_binary.ply", binary_ply(cube)), "refers to vertex 8");
}

TEST_F(surface_bad_input, RandomBytesInEveryFormat) {
  std::mt19937 random(12345);
  for (const char* extension : {".stl", ".obj", ".off", ".ply"}) {
    for (int sample = 0; sample < 8; ++sample) {
      std::string bytes(64 + 997 * sample, '\0');
      for (char& c : bytes) c = static_cast<char>(random() & 0xff);
      // Half the samples start like the format does, so the checks behind the first are hit.
      if (sample % 2 == 1) {
        const std::string start = std::string(extension) == ".stl"   ? "solid x\n"
                                  : std::string(extension) == ".obj" ? "v 0 0 0\n"
                                  : std::string(extension) == ".off" ? "OFF\n3 1 0\n"
                                                                     : "ply\nformat ascii 1.0\n";
        bytes.replace(0, start.size(), start);
      }
      SCOPED_TRACE(std::string(extension) + " sample " + std::to_string(sample));
      expect_input_error(write("random" + std::to_string(sample) + extension, bytes), "");
    }
  }
}

TEST_F(surface_bad_input, RandomTextInEveryFormat) {
  // Printable noise gets past the control-character checks and into the parsers.
  std::mt19937 random(777);
  const std::string alphabet = "0123456789 -+.eE\nvfsolidfacetnormalvertexOFFply#/";
  for (const char* extension : {".stl", ".obj", ".off", ".ply"}) {
    for (int sample = 0; sample < 8; ++sample) {
      std::string bytes(200 + 300 * sample, ' ');
      for (char& c : bytes) c = alphabet[random() % alphabet.size()];
      SCOPED_TRACE(std::string(extension) + " sample " + std::to_string(sample));
      expect_input_error(write("noise" + std::to_string(sample) + extension, bytes), "");
    }
  }
}

TEST_F(surface_bad_input, ZeroTrianglesInEveryFormat) {
  TriangleSurface no_faces = unit_cube();
  no_faces.triangles.clear();
  expect_input_error(write("empty_solid.stl", "solid nothing\nendsolid nothing\n"), "no triangles");
  expect_input_error(write("zero_count.stl", binary_stl(no_faces)), "no triangles");
  expect_input_error(write("vertices_only.obj", obj(no_faces)), "no triangles");
  expect_input_error(write("lines_only.obj", obj(no_faces) + "l 1 2 3\np 4\n"), "only points or lines");
  expect_input_error(write("no_faces.off", off(no_faces)), "no triangles");
  expect_input_error(write("no_faces.ply", ascii_ply(no_faces)), "no triangles");
  expect_input_error(write("no_vertices.ply", ascii_ply(TriangleSurface{})), "declares 0 vertices");
  expect_input_error(write("comment_only.obj", "# nothing here\n"), "no triangles");
}

TEST_F(surface_bad_input, AsciiStlStructureErrors) {
  const std::string cube = ascii_stl(unit_cube());
  std::string text = cube;
  text.replace(text.find("    endloop"), 0, "      vertex 2 2 2\n");
  expect_input_error(write("four_vertices.stl", text), "facet has 4 vertices");
  text = cube;
  text.replace(text.find("vertex 1 1 1"), 12, "vertex 1 blah 1");
  expect_input_error(write("blah.stl", text), "'blah' is not a number");
  text = cube;
  text.replace(text.find("normal 0 0 0"), 12, "normal");
  expect_input_error(write("no_normal.stl", text), "facet normal needs three numbers");
  expect_input_error(write("cut.stl", cube.substr(0, cube.find("vertex", cube.size() / 2) + 10)), "three coordinates");
  expect_input_error(write("cut_facet.stl", cube.substr(0, cube.find("outer loop", cube.size() / 2) + 10)),
                     "the file ends inside a facet");
  text = cube;
  text.replace(text.find("vertex 1 1 1"), 12, "vertex 1 \x10 1");
  expect_input_error(write("control.stl", text), "control character \\x10");
}

TEST_F(surface_bad_input, OffStructureErrors) {
  const std::string cube = off(unit_cube());
  std::string text = cube;
  text.replace(text.find("8 12 0"), 6, "8 12");
  expect_input_error(write("no_edge_count.off", text), "edge count is missing");
  text = cube;
  text.replace(text.find("8 12 0"), 6, "8 2000000000 0");
  expect_fast_input_error(write("many_faces.off", text), "ends after 12 of the 2000000000 faces");
  text = cube;
  text.replace(text.find("8 12 0"), 6, "353535235358 12 0");
  expect_fast_input_error(write("many_vertices.off", text), "353535235358 vertices");
  text = cube;
  // A comment between the faces is part of the format (tests/test_off.cpp reads every layout).
  text.replace(text.rfind("3 1 6 5"), 0, "# a comment\n");
  EXPECT_EQ(read_surface(write("comment.off", text)).triangles.size(), 12u);
  text = "OFF\n12 1 0\n";
  for (int i = 0; i < 12; ++i) text += number(std::cos(i * 0.5)) + " " + number(std::sin(i * 0.5)) + " 0\n";
  text += "12 0 1 2 3 4 5 6 7 8 9 10 11\n";
  expect_input_error(write("dodecagon.off", text), "at most 9");
  expect_input_error(write("one_line.off", "OFF\n3 1 0\n0 0 0 1 0 0 0 1 0\n3 0 1 2\n"),
                     "ends after 2 of the 3 vertices");
  expect_input_error(write("headerless.off", cube.substr(4)), "OFF header keyword");
  expect_input_error(write("binary.off", "OFF BINARY\n"), "binary OFF is not supported");
  expect_input_error(write("colour.off", "COFF\n3 1 0\n0 0 0 1 1 1 1\n1 0 0 red\n0 1 0 1 1 1 1\n3 0 1 2\n"),
                     "line 4: 'red' is not a number");
  expect_input_error(write("normal.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0\n0 1 0 0 0 1\n3 0 1 2\n"),
                     "asks for 6 values per vertex, found 3");
}

TEST_F(surface_bad_input, PlyHeaderErrors) {
  const TriangleSurface cube = unit_cube();
  std::string text = binary_ply(cube);
  text.replace(text.find("element vertex 8"), 16, "element vertex 2000000000");
  expect_fast_input_error(write("many_vertices.ply", text), "2000000000 'vertex' elements");
  text = ascii_ply(cube);
  text.replace(text.find("element face 12"), 15, "element face 4000000000");
  expect_fast_input_error(write("many_faces.ply", text), "truncated or corrupt");
  const std::string binary = binary_ply(cube);
  expect_input_error(write("truncated.ply", binary.substr(0, binary.size() - 10)), "truncated or corrupt");
  text = ascii_ply(cube);
  expect_input_error(write("no_end.ply", text.substr(0, text.find("end_header"))), "end_header");
  expect_input_error(write("not.ply", "plx\n" + text.substr(4)), "not a PLY file");
  text.replace(text.find("ascii"), 5, "morse");
  expect_input_error(write("morse.ply", text), "unknown PLY format 'morse'");
  // Assimp 5.2 writes past a buffer on a repeated element.
  text = binary_ply(cube);
  text.replace(text.find("element face"), 0,
               "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n");
  expect_input_error(write("two_vertex_elements.ply", text), "'vertex' is declared twice");
  text = ascii_ply(cube);
  text.replace(text.find("property float y"), 0, "made by hand\n");
  expect_input_error(write("stray_property.ply", text), "does not follow an element");
  text = ascii_ply(cube);
  text.replace(text.find("property float z"), 16, "property float w");
  expect_input_error(write("no_z.ply", text), "no 'vertex' element with x, y and z");
  // Assimp 5.2 counts an element it does not know as empty and reads on out of step.
  text = ascii_ply(cube);
  text.replace(text.find("end_header"), 0, "element range_grid 1\nproperty list uchar int vertex_indices\n");
  expect_input_error(write("range_grid.ply", text + "0\n"), "'range_grid' is not supported");
  text = ascii_ply(cube);
  text.replace(text.find("element face"), 12, "element tristrips");
  expect_input_error(write("tristrips.ply", text), "'tristrips' is not supported");
  text = binary_ply(cube);
  for (std::size_t at = text.find('\n'); at < text.find("end_header"); at = text.find('\n', at + 1)) text[at] = '\r';
  expect_input_error(write("carriage_returns.ply", text), "bare carriage return");
}

TEST_F(surface_read, BinaryPlyWhoseDataStartsWithALineFeed) {
  // Assimp 5.2 alone skips the 0x0a and reads every value one byte out of step.
  TriangleSurface cube = unit_cube();
  const uint32_t bits = 0x3f80000au;  // little-endian bytes 0a 00 80 3f: just above 1
  float x;
  std::memcpy(&x, &bits, 4);
  cube.vertices[0].x = x;
  const std::string plain = binary_ply(cube);
  std::string with_edges = plain;
  with_edges.replace(with_edges.find("end_header"), 0, "element edge 1\nproperty int vertex1\nproperty int vertex2\n");
  with_edges += le32(0) + le32(1);
  for (const auto& [name, bytes] : {std::pair{"line_feed.ply", plain}, std::pair{"line_feed_edges.ply", with_edges}}) {
    SCOPED_TRACE(name);
    ASSERT_EQ(bytes[bytes.find("end_header\n") + 11], '\n');
    const TriangleSurface s = read_surface(write(name, bytes));
    EXPECT_EQ(s.vertices.front().x, double(x));
    const SurfaceReport r = validate_surface(s);
    EXPECT_EQ(r.vertices, 8u);
    EXPECT_EQ(r.triangles, 12u);
    EXPECT_TRUE(r.consistently_oriented);
  }
}

TEST_F(surface_bad_input, PlyAsciiDataErrors) {
  const std::string cube = ascii_ply(unit_cube());
  std::string text = cube;
  text.replace(text.find("1 1 1\n"), 6, "1 1 1 0 1 1\n");
  expect_input_error(write("merged.ply", text), "one element per line");
  text = cube;
  text.replace(text.find("1 1 1\n"), 6, "1 1\n");
  expect_input_error(write("short.ply", text), "too few values for a 'vertex' element");
  text = cube;
  text.replace(text.find("1 1 1\n"), 0, "\n");
  expect_input_error(write("blank.ply", text), "blank line");
  text = cube;
  text.replace(text.find("3 1 6 5"), 7, "3 1 6 5.5");
  expect_input_error(write("fraction.ply", text), "'5.5' is not an integer");
  text = cube;
  text.replace(text.find("1 1 1\n"), 6, "1 one 1\n");
  expect_input_error(write("word.ply", text), "'one' is not a number");
}

TEST_F(surface_bad_input, Utf16Obj) {
  std::string text = "\xFE\xFF";
  for (char c : obj(unit_cube())) text += std::string(1, '\0') + c;
  expect_input_error(write("utf16.obj", text), "UTF-16");
}

TEST_F(surface_bad_input, HugePolygonsAreRefused) {
  // Ear clipping is quadratic in the corners; a corrupt face must not become an hour-long loop.
  std::string text;
  const int corners = 5000;
  for (int i = 0; i < corners; ++i)
    text += "v " + number(std::cos(i * 2e-3)) + " " + number(std::sin(i * 2e-3)) + " 0\n";
  text += "f";
  for (int i = 1; i <= corners; ++i) text.append(" ").append(std::to_string(i));
  expect_fast_input_error(write("polygon.obj", text + "\n"), "5000 corners");
  TriangleSurface fan;
  for (int i = 0; i < corners; ++i) fan.vertices.push_back({std::cos(i * 2e-3), std::sin(i * 2e-3), 0});
  std::string ply = ascii_ply(fan);
  ply.replace(ply.find("element face 0"), 14, "element face 1");
  ply += std::to_string(corners);
  for (int i = 0; i < corners; ++i) ply.append(" ").append(std::to_string(i));
  ply.replace(ply.find("list uchar int"), 14, "list int int");
  expect_fast_input_error(write("polygon.ply", ply + "\n"), "5000 corners");
}

// ---------------------------------------------------------------------------------------------
// Sample files shipped by Debian (assimp-testmodels, openscad) and npm (stl-models)

const fs::path kAssimpModels = "/usr/share/assimp/models";
const fs::path kOpenscadStl = "/usr/share/openscad/testdata/stl";
const fs::path kNpmStl = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models";

#define REQUIRE_DIR(dir) \
  if (!fs::is_directory(dir)) GTEST_SKIP() << (dir) << " is not installed"

struct Expected {
  const char* file;
  const char* error;  // nullptr: reads; otherwise part of the reason
  std::size_t triangles = 0;
  bool consistently_oriented = false;
  double volume = 0;
};

void check_samples(const fs::path& dir, const std::vector<Expected>& expected) {
  for (const Expected& e : expected) {
    const fs::path path = dir / e.file;
    SCOPED_TRACE(path.string());
    if (e.error != nullptr) {
      expect_input_error(path, e.error);
      continue;
    }
    const SurfaceReport r = validate_surface(read_surface(path));
    EXPECT_EQ(r.triangles, e.triangles);
    EXPECT_EQ(r.consistently_oriented, e.consistently_oriented);
    if (e.volume != 0) {
      EXPECT_NEAR(r.volume, e.volume, 1e-6 * std::abs(e.volume));
    }
  }
}

TEST(surface_samples, Openscad) {
  REQUIRE_DIR(kOpenscadStl);
  check_samples(kOpenscadStl, {
                                  {"empty.stl", "empty"},
                                  {"empty2.stl", "no triangles"},
                                  {"invalidvertex.stl", "line 89: 'blah' is not a number"},
                                  {"toomanyvertices.stl", "facet has 4 vertices"},
                                  {"unparseable.stl", "line 4: control character"},
                                  {"adns2610_dev_circuit_inv.stl", nullptr, 900, true, 0},
                              });
}

TEST(surface_samples, NpmStlModels) {
  REQUIRE_DIR(kNpmStl);
  check_samples(kNpmStl,
                {
                    {"polytopes/cube.ascii.stl", nullptr, 12, true, 8},
                    {"polytopes/cube.bin.stl", nullptr, 12, true, 8},
                    {"polytopes/unitCube.ascii.stl", nullptr, 12, true, 1},
                    {"polytopes/unitCube.binary.stl", nullptr, 12, true, 1},
                    {"polytopes/tetrahedron.ascii.stl", nullptr, 4, true, 1.0 / 6},
                    {"polytopes/tetrahedron.min.ascii.stl", nullptr, 4, true, 1.0 / 6},
                    {"polytopes/tetrahedronMinusZero.bin.stl", nullptr, 4, true, 1.0 / 6},
                    {"polytopes/triangle.ascii.stl", nullptr, 1, false, 0},
                    {"objects/gearwheel.bin.stl", nullptr, 2444, true, 0},
                    {"broken/empty.stl", "empty"},
                    {"broken/fourVertices.ascii.stl", "line 2: facet has 4 vertices"},
                    {"broken/quad.ascii.stl", "facet has 4 vertices"},
                    {"broken/twoVertices.ascii.stl", "facet has 2 vertices"},
                    {"broken/incorrectFaceCounter.bin.stl", "declares 66 triangles"},
                    {"broken/missingNormal.ascii.stl", "facet normal needs three numbers"},
                    {"broken/missingFace.ascii.stl", nullptr, 3, false, 0},  // open: the report says so
                    {"broken/missingEndsolid.ascii.stl", nullptr, 4, true, 1.0 / 6},
                    {"broken/notANumberNormal.ascii.stl", nullptr, 4, true, 1.0 / 6},  // normals are not used
                    {"broken/wrongNormals.ascii.stl", nullptr, 4, true, 1.0 / 6},
                    {"broken/solidNameMismatch.ascii.stl", nullptr, 4, true, 1.0 / 6},
                    {"broken/singleFace.ascii.stl", nullptr, 1, false, 0},
                    {"broken/wrongHeader.bin.stl", nullptr, 12, true, 1e6},
                    {"misc/faceless.ascii.stl", "no triangles"},
                    {"misc/multiWordName.bin.stl", "declares 4 triangles, which need 284 bytes, but the file has 333"},
                });
  // -0 and +0 weld: the minus-zero tetrahedron has the same four corners as the plain one.
  EXPECT_EQ(read_surface(kNpmStl / "polytopes/tetrahedronMinusZero.bin.stl").vertices.size(), 4u);
  // The ascii and binary bunny are the same surface.
  const SurfaceReport ascii = validate_surface(read_surface(kNpmStl / "objects/bunny.ascii.stl"));
  const SurfaceReport binary = validate_surface(read_surface(kNpmStl / "objects/bunny.bin.stl"));
  EXPECT_EQ(ascii.triangles, 69451u);
  EXPECT_EQ(ascii.vertices, binary.vertices);
  EXPECT_EQ(ascii.edges, binary.edges);
  EXPECT_EQ(ascii.boundary_edges, binary.boundary_edges);
}

TEST(surface_samples, AssimpModels) {
  REQUIRE_DIR(kAssimpModels);
  check_samples(kAssimpModels,
                {
                    {"OFF/Cube.off", nullptr, 12, true, 1},
                    {"OFF/invalid.off", "edge count is missing"},
                    {"PLY/cube.ply", nullptr, 12, true, 1},
                    {"PLY/cube_binary.ply", nullptr, 12, true, 1},
                    {"PLY/Wuson.ply", nullptr, 3732, false, 0},
                    {"PLY/points.ply", "no triangles"},
                    {"PLY/pond.0.ply", "truncated or corrupt"},
                    {"OBJ/box.obj", nullptr, 12, true, 1},
                    {"OBJ/testmixed.obj", nullptr, 12, true, 1},
                    {"OBJ/testline.obj", "only points or lines"},
                    {"OBJ/box_UTF16BE.obj", "UTF-16"},
                    {"OBJ/number_formats.obj", "'3.1+e2' is not a number"},
                    {"STL/triangle_with_two_solids.stl", nullptr, 2, false, 0},
                    {"invalid/empty.off", "empty"},
                    {"invalid/malformed.obj", "line 23: face refers to vertex 12"},
                    {"invalid/malformed2.obj", nullptr, 10, false, 0},  // an empty 'f' and a missing material
                });
  expect_fast_input_error(kAssimpModels / "invalid/OutOfMemory.off", "353535235358 vertices");
  const SurfaceReport ascii = validate_surface(read_surface(kAssimpModels / "STL/Spider_ascii.stl"));
  const SurfaceReport binary = validate_surface(read_surface(kAssimpModels / "STL/Spider_binary.stl"));
  EXPECT_EQ(ascii.triangles, 1368u);
  EXPECT_EQ(ascii.vertices, binary.vertices);
  EXPECT_EQ(ascii.edges, binary.edges);
  EXPECT_EQ(ascii.components, binary.components);
}

// Whatever a sample holds, reading it ends in a surface or an InputError, silently.
TEST(surface_samples, EverySampleReadsOrFailsCleanly) {
  std::vector<fs::path> roots = {kAssimpModels / "STL",
                                 kAssimpModels / "OBJ",
                                 kAssimpModels / "OFF",
                                 kAssimpModels / "PLY",
                                 kAssimpModels / "invalid",
                                 kOpenscadStl,
                                 kNpmStl};
  std::size_t files = 0;
  for (const fs::path& root : roots) {
    if (!fs::is_directory(root)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(root)) {
      std::string extension = entry.path().extension().string();
      for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (!entry.is_regular_file() ||
          (extension != ".stl" && extension != ".obj" && extension != ".off" && extension != ".ply"))
        continue;
      SCOPED_TRACE(entry.path().string());
      ++files;
      testing::internal::CaptureStdout();
      testing::internal::CaptureStderr();
      try {
        const TriangleSurface s = read_surface(entry.path());
        EXPECT_FALSE(s.triangles.empty());
        for (const Vec3& v : s.vertices) ASSERT_TRUE(is_finite(v));
        validate_surface(s);
      } catch (const InputError& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
        EXPECT_EQ(message.rfind(entry.path().string() + ": ", 0), 0u) << message;
      }
      EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
      EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    }
  }
  if (files == 0) GTEST_SKIP() << "no sample files installed";
  RecordProperty("sample_files", static_cast<int>(files));
}

}  // namespace
}  // namespace mchex
