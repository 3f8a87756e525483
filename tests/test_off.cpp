// OFF files in every layout the format allows (core/io/off.cpp): comments after the header
// keyword, between the counts and the vertices, between and after vertices and faces; blank lines
// and lines of spaces anywhere; per-vertex normals, colours, texture coordinates and a
// homogeneous w; per-face colours of 0 to 4 values. Each variant is written here from one cube,
// read back, and compared with the cube itself: the triangle count, every coordinate, the volume.
// Malformed files still fail with one line that says what is wrong.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/base/error.h"
#include "core/io/surface_io.h"
#include "core/mesh/surface.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

// An off-centre cube (no coordinate is its own mirror image), 12 triangles outward.
const std::vector<Vec3> kCorners = {{0.25, -1.5, 3}, {1.25, -1.5, 3}, {1.25, -0.5, 3}, {0.25, -0.5, 3},
                                    {0.25, -1.5, 4}, {1.25, -1.5, 4}, {1.25, -0.5, 4}, {0.25, -0.5, 4}};
const std::vector<std::vector<int>> kQuads = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                              {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};

std::string fmt3(const Vec3& v, double scale = 1) {
  return std::to_string(v.x * scale) + " " + std::to_string(v.y * scale) + " " + std::to_string(v.z * scale);
}

struct Layout {
  std::string header;                // keyword line(s) and counts, with any comments
  std::string (*vertex_extra)(int);  // what follows a vertex's position
  std::string (*face_extra)(int);    // what follows a face's indices
  std::string between = "";          // put between records
  double scale = 1;                  // 4OFF: positions written times w
};

std::string write_layout(const Layout& l) {
  std::string text = l.header;
  for (std::size_t i = 0; i < kCorners.size(); ++i)
    text.append(fmt3(kCorners[i], l.scale)).append(l.vertex_extra(int(i))).append("\n").append(l.between);
  for (std::size_t f = 0; f < kQuads.size(); ++f) {
    text += "4";
    for (int v : kQuads[f]) text.append(" ").append(std::to_string(v));
    text.append(l.face_extra(int(f))).append("\n").append(l.between);
  }
  return text;
}

class off_read : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mchex_test_off_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  // The surface read back is the cube: 12 triangles, its 8 corners to float precision, volume 1.
  void expect_cube(const std::string& name, const std::string& text) const {
    SCOPED_TRACE(name + ":\n" + text);
    const TriangleSurface s = read_surface(write(name, text));
    ASSERT_EQ(s.triangles.size(), 12u);
    ASSERT_EQ(s.vertices.size(), 8u);
    std::vector<Vec3> got = s.vertices, want = kCorners;
    const auto less = [](const Vec3& a, const Vec3& b) {
      return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
    };
    std::sort(got.begin(), got.end(), less);
    std::sort(want.begin(), want.end(), less);
    for (std::size_t i = 0; i < 8; ++i) {
      EXPECT_NEAR(got[i].x, want[i].x, 1e-6);
      EXPECT_NEAR(got[i].y, want[i].y, 1e-6);
      EXPECT_NEAR(got[i].z, want[i].z, 1e-6);
    }
    const SurfaceReport r = validate_surface(s);
    EXPECT_TRUE(r.consistently_oriented);
    EXPECT_NEAR(r.volume, 1.0, 1e-6);
  }
  fs::path dir_;
};

std::string none(int) { return ""; }

TEST_F(off_read, CommentsAndBlankLinesAnywhere) {
  Layout l;
  l.header = "OFF # the keyword's comment\n# a comment line\n\n   \n8 6 0 # counts\n# before the vertices\n\t\n";
  l.vertex_extra = [](int i) { return std::string(i % 2 ? " # vertex comment" : "#glued"); };
  l.face_extra = [](int f) { return std::string(f % 2 ? "  # face comment" : ""); };
  l.between = "# between records\n\n  \t \n";
  expect_cube("comments.off", write_layout(l));
  // CRLF line ends, the counts on the keyword's line, a comment as the last line without an end.
  l.header = "OFF 8 6 0\r\n";
  std::string text = write_layout(l);
  text += "# the end";
  std::string crlf;
  for (const char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  text = crlf;
  expect_cube("crlf.off", text);
}

TEST_F(off_read, VertexAndFaceColours) {
  Layout l;
  l.header = "COFF\n8 6 12\n";
  l.vertex_extra = [](int i) { return i % 2 ? std::string(" 0.5 0.25 1 1") : std::string(" 255 128 0 255"); };
  // A face's colour: nothing, a colour-map index, RGB or RGBA, integers or fractions.
  l.face_extra = [](int f) {
    const char* colours[] = {"", " 7", " 255 0 0", " 0.1 0.2 0.3 0.4", " 1 1 1 1", ""};
    return std::string(colours[f]);
  };
  expect_cube("coff.off", write_layout(l));
  l.header = "OFF\n8 6 0\n";
  l.vertex_extra = none;
  expect_cube("face_colours.off", write_layout(l));
}

TEST_F(off_read, NormalsTextureCoordinatesAndW) {
  Layout l;
  l.face_extra = none;
  l.header = "NOFF\n8 6 0\n";
  l.vertex_extra = [](int) { return std::string(" 0 0 1"); };
  expect_cube("noff.off", write_layout(l));
  l.header = "STOFF\n8 6 0\n";
  l.vertex_extra = [](int i) {
    std::string s = " 0.";
    s += std::to_string(i);
    s += " 0.5";
    return s;
  };
  expect_cube("stoff.off", write_layout(l));
  l.header = "STCNOFF\n8 6 0\n";
  l.vertex_extra = [](int) { return std::string(" 0 0 1 0.2 0.4 0.6 1 0.5 0.5"); };
  expect_cube("stcnoff.off", write_layout(l));
  // Homogeneous: every position written times w = 2, with w after it.
  l.header = "4OFF\n8 6 0\n";
  l.vertex_extra = [](int) { return std::string(" 2"); };
  l.scale = 2;
  expect_cube("4off.off", write_layout(l));
  // nOFF: the dimension on its own line.
  l.header = "nOFF # dimension next\n3\n8 6 0\n";
  l.vertex_extra = none;
  l.scale = 1;
  expect_cube("noff_dimension.off", write_layout(l));
}

// One line, naming the file and what is wrong.
std::string error_of(const fs::path& path) {
  try {
    read_surface(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_F(off_read, MalformedFilesStillFailWithOneLine) {
  Layout l;
  l.header = "OFF\n8 6 0\n";
  l.vertex_extra = none;
  l.face_extra = none;
  const std::string cube = write_layout(l);
  struct Case {
    std::string name, text, reason;
  } cases[] = {
      {"cut_face.off",
       [&] {
         std::string t = cube;
         t.replace(t.find("4 0 3 2 1"), 9, "4 0 3 # 2 1");
         return t;
       }(),
       "line 11: face has fewer indices than its corner count 4"},
      {"cut_vertex.off",
       [&] {
         std::string t = cube;
         t.insert(t.find(' ', 10), " #");  // the first vertex keeps only its x
         return t;
       }(),
       "line 3: a vertex needs three coordinates"},
      {"zero_w.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 0\n0 1 0 1\n3 0 1 2\n", "line 4: the homogeneous coordinate w"},
      {"only_comments.off", "OFF\n# nothing but comments\n# here\n", "ends inside the OFF header"},
      {"short.off", "OFF\n3 1 0\n0 0 0\n# 1 0 0\n0 1 0\n3 0 1 2\n", "ends after 0 of the 1 faces"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string message = error_of(write(c.name, c.text));
    EXPECT_NE(message.find(c.name), std::string::npos) << message;
    EXPECT_NE(message.find(c.reason), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace mchex
