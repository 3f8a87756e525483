// Mesh files: exact round trips, atomic writes, files from other tools, and bad files that must
// fail with an InputError naming the file. tests/test_meshio_formats.py drives the two
// HexmeshSamples tests to check the same files against meshio, an independent reader and writer.
#include "core/io/mesh_io.h"

#include <sys/resource.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/text_numbers.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

// The sample that test_meshio_formats.py rebuilds on its own: a 2x2x2 block of hexes on a 3x3x3
// lattice, point p = i + 3j + 9k at (i/3, j*0.1, k), with a few coordinates replaced by values
// that only an exact round trip keeps (signed zero, subnormals, extremes, 0.1+0.2), and mixed,
// interleaved regions. Corners are in VTK_HEXAHEDRON order.
HexMesh sample_mesh() {
  HexMesh mesh;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) mesh.points.push_back({i / 3.0, j * 0.1, static_cast<double>(k)});
  mesh.points[0] = {-0.0, 1e-17, 1.0 / 3.0};
  mesh.points[4].x = 1e300;
  mesh.points[13] = {5e-324, -1.7976931348623157e308, 0.1 + 0.2};
  mesh.points[26].z = -2.2250738585072014e-308;
  for (uint32_t k = 0; k < 2; ++k)
    for (uint32_t j = 0; j < 2; ++j)
      for (uint32_t i = 0; i < 2; ++i) {
        const uint32_t b = i + 3 * j + 9 * k;
        mesh.hexes.push_back({b, b + 1, b + 4, b + 3, b + 9, b + 10, b + 13, b + 12});
      }
  mesh.region = {1, 2, 2, 1, 3, 1, 1, 2};
  return mesh;
}

// An n x n x n block of unit hexes, large enough that writes go through several chunks.
HexMesh grid_mesh(uint32_t n) {
  HexMesh mesh;
  const uint32_t s = n + 1;
  for (uint32_t k = 0; k < s; ++k)
    for (uint32_t j = 0; j < s; ++j)
      for (uint32_t i = 0; i < s; ++i) mesh.points.push_back({i * 0.7, j / 3.0, k * 1e-3});
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t b = i + s * j + s * s * k;
        mesh.hexes.push_back({b, b + 1, b + 1 + s, b + s, b + s * s, b + 1 + s * s, b + 1 + s + s * s, b + s + s * s});
        mesh.region.push_back(static_cast<int32_t>(1 + (i + j + k) % 3));
      }
  return mesh;
}

class TempDir {
 public:
  TempDir() {
    static std::atomic<int> serial{0};
    path_ =
        fs::temp_directory_path() / ("mchex_mesh_io_" + std::to_string(::getpid()) + "_" + std::to_string(serial++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_bytes(const fs::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

void expect_same_mesh(const HexMesh& expected, const HexMesh& got) {
  ASSERT_EQ(expected.points.size(), got.points.size());
  for (std::size_t i = 0; i < expected.points.size(); ++i)
    for (int a = 0; a < 3; ++a)
      ASSERT_EQ(std::bit_cast<uint64_t>(expected.points[i][a]), std::bit_cast<uint64_t>(got.points[i][a]))
          << "point " << i << " axis " << a << ": " << expected.points[i][a] << " vs " << got.points[i][a];
  EXPECT_EQ(expected.hexes, got.hexes);
  EXPECT_EQ(expected.region, got.region);
}

// The message of the InputError that `f` throws; a test failure if it throws anything else.
std::string input_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected InputError, nothing was thrown";
  return {};
}

// The message must be one line that starts with the path and contains `reason`.
void expect_read_error(const fs::path& path, const std::string& reason) {
  const std::string message = input_error([&] { read_hex_mesh(path); });
  EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
  EXPECT_NE(message.find(reason), std::string::npos) << "message: " << message << "\nwanted: " << reason;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

void expect_read_error(const TempDir& dir, const std::string& name, std::string_view content,
                       const std::string& reason) {
  SCOPED_TRACE(name + ":\n" + std::string(content));
  const fs::path path = dir / name;
  write_bytes(path, content);
  expect_read_error(path, reason);
}

HexMesh read_text(const TempDir& dir, const std::string& name, std::string_view content) {
  const fs::path path = dir / name;
  write_bytes(path, content);
  return read_hex_mesh(path);
}

// A mesh that any successful read must return: consistent indices, labels and coordinates.
void expect_consistent(const HexMesh& mesh) {
  ASSERT_EQ(mesh.hexes.size(), mesh.region.size());
  for (const Vec3& p : mesh.points) ASSERT_TRUE(is_finite(p));
  for (const Hex& h : mesh.hexes)
    for (const uint32_t v : h) ASSERT_LT(v, mesh.points.size());
}

// Makes writes past `bytes` fail with EFBIG, as a full disk would, for the scope of the object.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limit = old_;
    limit.rlim_cur = bytes;
    EXPECT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  }
  ~FileSizeLimit() { setrlimit(RLIMIT_FSIZE, &old_); }

 private:
  rlimit old_{};
};

// ---------------------------------------------------------------------------------------------
// Every format

// A format under test: the file extension, and whether .msh is written as binary.
struct FormatCase {
  std::string extension;
  bool binary = false;
};

class EveryFormat : public ::testing::TestWithParam<FormatCase> {
 protected:
  fs::path file(const std::string& stem = "sample") const { return dir_ / (stem + GetParam().extension); }
  void write(const HexMesh& mesh, const fs::path& path) const {
    MeshWriteOptions options;
    options.binary = GetParam().binary;
    write_hex_mesh(mesh, path, options);
  }
  std::string lower_extension() const {
    std::string e = GetParam().extension;
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
  }
  // .inp rounds a coordinate whose shortest exact form is over CalculiX's 20 characters.
  void expect_round_trip(const HexMesh& expected, const HexMesh& got) const {
    if (lower_extension() != ".inp") return expect_same_mesh(expected, got);
    ASSERT_EQ(expected.points.size(), got.points.size());
    for (std::size_t i = 0; i < expected.points.size(); ++i)
      for (int a = 0; a < 3; ++a) {
        const double want = expected.points[i][a];
        char shortest[32];
        const bool fits = std::to_chars(shortest, shortest + 32, want).ptr - shortest <= 20;
        if (fits) ASSERT_EQ(std::bit_cast<uint64_t>(want), std::bit_cast<uint64_t>(got.points[i][a])) << "point " << i;
        else ASSERT_LE(std::abs(got.points[i][a] - want), 5e-13 * std::abs(want)) << "point " << i;
      }
    EXPECT_EQ(expected.hexes, got.hexes);
    EXPECT_EQ(expected.region, got.region);
  }
  // An Abaqus deck has no counts and no end marker: one cut at a line end is a smaller valid deck.
  bool truncation_shows() const { return lower_extension() != ".inp"; }
  TempDir dir_;
};

INSTANTIATE_TEST_SUITE_P(Hexmesh, EveryFormat,
                         ::testing::Values(FormatCase{".mesh"}, FormatCase{".vtu"}, FormatCase{".msh"},
                                           FormatCase{".MESH"}, FormatCase{".Vtu"}, FormatCase{".MSH"},
                                           FormatCase{".meshb"}, FormatCase{".MeshB"}, FormatCase{".msh", true},
                                           FormatCase{".exo"}, FormatCase{".EXO"}, FormatCase{".inp"},
                                           FormatCase{".INP"}),
                         [](const auto& info) {
                           std::string name = info.param.extension.substr(1);
                           return name + (std::any_of(name.begin(), name.end(), ::isupper) ? "_upper" : "") +
                                  (info.param.binary ? "_binary" : "");
                         });

TEST_P(EveryFormat, SampleRoundTripIsBitExact) {
  const HexMesh mesh = sample_mesh();
  write(mesh, file());
  expect_round_trip(mesh, read_hex_mesh(file()));
  EXPECT_EQ(listing(dir_.path()), std::vector<std::string>{file().filename().string()}) << "temporary file left";
}

TEST_P(EveryFormat, LargerMeshRoundTrip) {
  const HexMesh mesh = grid_mesh(40);  // 64000 hexes: several chunks per table
  write(mesh, file());
  expect_round_trip(mesh, read_hex_mesh(file()));
}

TEST_P(EveryFormat, EmptyMeshesRoundTrip) {
  HexMesh points_only;
  points_only.points = {{1, 2, 3}, {-0.0, 0.5, 1e-300}};
  for (const HexMesh& mesh : {HexMesh{}, points_only}) {
    write(mesh, file());
    expect_round_trip(mesh, read_hex_mesh(file()));
  }
}

TEST_P(EveryFormat, AnyInt32RegionRoundTrips) {
  HexMesh mesh = sample_mesh();
  mesh.region = {0, -3, 7, std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max(), 0, 0, 7};
  write(mesh, file());
  expect_round_trip(mesh, read_hex_mesh(file()));
}

TEST_P(EveryFormat, ReplacesAnExistingFile) {
  write(grid_mesh(3), file());
  const HexMesh mesh = sample_mesh();
  write(mesh, file());
  expect_round_trip(mesh, read_hex_mesh(file()));
  EXPECT_EQ(listing(dir_.path()).size(), 1u);
}

TEST_P(EveryFormat, DiskErrorKeepsTheOldFileAndLeavesNoTemporary) {
  write_bytes(file(), "old");
  std::string message;
  {
    FileSizeLimit limit(64 * 1024);
    message = input_error([&] { write(grid_mesh(30), file()); });
  }
  EXPECT_EQ(message.rfind(file().string() + ": write failed: ", 0), 0u) << message;
  EXPECT_EQ(read_bytes(file()), "old");
  EXPECT_EQ(listing(dir_.path()), std::vector<std::string>{file().filename().string()});
}

TEST_P(EveryFormat, EveryTruncationIsAnError) {
  if (!truncation_shows()) GTEST_SKIP() << "a format without counts or end marker";
  write(sample_mesh(), file());
  const std::string full = read_bytes(file());
  std::size_t complete = full.size();
  while (complete > 0 && (full[complete - 1] == '\n' || full[complete - 1] == ' ')) --complete;
  const fs::path cut = file("cut");
  for (std::size_t size = 0; size < complete; ++size) {
    SCOPED_TRACE("first " + std::to_string(size) + " of " + std::to_string(full.size()) + " bytes");
    write_bytes(cut, std::string_view(full).substr(0, size));
    const std::string message = input_error([&] { read_hex_mesh(cut); });
    ASSERT_EQ(message.rfind(cut.string() + ": ", 0), 0u) << message;
  }
}

TEST_P(EveryFormat, CorruptedBytesGiveAMeshOrAnInputError) {
  write(sample_mesh(), file());
  const std::string full = read_bytes(file());
  const std::string interesting = "0123456789 \n-+.eE$<>\"'_=/#xAZ\x80\xff";
  std::mt19937 random(12345);
  const fs::path bad = file("bad");
  for (int trial = 0; trial < 400; ++trial) {
    std::string bytes = full;
    const int flips = 1 + trial % 3;
    for (int f = 0; f < flips; ++f) {
      const std::size_t at = random() % bytes.size();
      bytes[at] = trial % 2 == 0 ? interesting[random() % interesting.size()] : static_cast<char>(random() % 256);
    }
    SCOPED_TRACE("trial " + std::to_string(trial));
    write_bytes(bad, bytes);
    try {
      expect_consistent(read_hex_mesh(bad));
    } catch (const InputError& e) {
      ASSERT_EQ(std::string(e.what()).rfind(bad.string() + ": ", 0), 0u) << e.what();
    }
  }
}

TEST_P(EveryFormat, MissingFileNamesThePath) { expect_read_error(file("absent"), "No such file"); }

TEST_P(EveryFormat, DirectoryIsNotAMeshFile) {
  fs::create_directory(file("folder"));
  expect_read_error(file("folder"), "not a regular file");
}

// ---------------------------------------------------------------------------------------------
// Numbers

// The writers print integers eight digits at a time (text_numbers.h); the characters must be
// std::to_chars's for every length and sign.
TEST(HexmeshNumbers, PutDecimalIsToChars) {
  std::vector<std::int64_t> values = {0,
                                      1,
                                      9,
                                      10,
                                      99,
                                      100,
                                      12345678,
                                      99999999,
                                      100000000,
                                      4294967295,
                                      4294967296,
                                      9999999999999999,
                                      10000000000000000,
                                      std::numeric_limits<std::int64_t>::max(),
                                      std::numeric_limits<std::int64_t>::min(),
                                      std::numeric_limits<int32_t>::min()};
  std::mt19937_64 random(3);
  for (int i = 0; i < 200000; ++i) values.push_back(static_cast<std::int64_t>(random() >> (random() % 64)));
  for (std::uint64_t p = 1; p < 10000000000000000000ull; p *= 10)
    for (const std::uint64_t v : {p - 1, p, p + 1}) values.push_back(static_cast<std::int64_t>(v));
  for (const std::int64_t v : values) {
    for (const std::int64_t w : {v, -v}) {
      char want[32], got[io_detail::kNumberRoom];
      const std::string_view expected(want, static_cast<std::size_t>(std::to_chars(want, want + 32, w).ptr - want));
      ASSERT_EQ(std::string_view(got, static_cast<std::size_t>(io_detail::put_decimal(got, w) - got)), expected);
      const auto u = static_cast<std::uint64_t>(w);
      const std::string_view unsigned_expected(want,
                                               static_cast<std::size_t>(std::to_chars(want, want + 32, u).ptr - want));
      ASSERT_EQ(std::string_view(got, static_cast<std::size_t>(io_detail::put_decimal(got, u) - got)),
                unsigned_expected);
    }
  }
}

// Doubles: put_real's exact path (0.001 < |v| < 2^50) and std::to_chars elsewhere must give
// std::to_chars's characters: shortest digits, nearest on ties, fixed or scientific as it chooses.
// Every exponent by random bit patterns; the path's own range densely; short decimals, powers of
// two and their neighbours, where the rounding interval's ends and the even-digit rule decide.
TEST(HexmeshNumbers, PutRealIsToChars) {
  std::mt19937_64 random(11);
  const auto expect_same = [&](double v) {
    char want[64], got[80];
    const std::string_view expected(want, static_cast<std::size_t>(std::to_chars(want, want + 64, v).ptr - want));
    ASSERT_EQ(std::string_view(got, static_cast<std::size_t>(io_detail::put_real(got, v) - got)), expected);
    // Within this range the exact path must be the one taken.
    if (std::abs(v) >= 0.002 && std::abs(v) < 1e15) {
      ASSERT_NE(io_detail::number_detail::put_real_exact(got, v), nullptr) << v;
    }
  };
  for (int i = 0; i < 1500000; ++i) {
    const std::uint64_t bits = random();
    // Any pattern, then the same mantissa and sign at an exponent within 2^-14 .. 2^56.
    const std::uint64_t near = (bits & 0x800FFFFFFFFFFFFFull) | ((1009 + random() % 70) << 52);
    for (const std::uint64_t b : {bits, near}) {
      const double v = std::bit_cast<double>(b);
      if (std::isfinite(v)) expect_same(v);
    }
  }
  for (int e = -330; e <= 310; ++e)
    for (int d = 1; d < 400; ++d)
      for (const double v : {d * std::pow(10.0, e), std::ldexp(d, e)})
        for (const double w : {v, std::nextafter(v, 0.0), std::nextafter(v, HUGE_VAL)}) {
          expect_same(w);
          expect_same(-w);
        }
  for (const double v : {0.0, -0.0, 0.001, 0.1, 0.3, 1.0, 2.5, 1e15, 0x1p50, 0x1p53, 5e-324, 2.2250738585072014e-308,
                         1.7976931348623157e308})
    expect_same(v);
}

// ---------------------------------------------------------------------------------------------
// Atomic writes

TEST(HexmeshWrite, MissingFolderThrowsAndCreatesNothing) {
  TempDir dir;
  const fs::path path = dir / "no/such/out.mesh";
  const std::string message = input_error([&] { write_hex_mesh(sample_mesh(), path); });
  EXPECT_EQ(message.rfind(path.string() + ": cannot create a file in ", 0), 0u) << message;
  EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
  EXPECT_TRUE(listing(dir.path()).empty());
}

TEST(HexmeshWrite, InconsistentMeshKeepsTheOldFile) {
  TempDir dir;
  const fs::path path = dir / "out.vtu";
  write_bytes(path, "old");
  HexMesh bad_index = sample_mesh();
  bad_index.hexes[5][6] = 27;
  HexMesh bad_regions = sample_mesh();
  bad_regions.region.pop_back();
  HexMesh bad_point = sample_mesh();
  bad_point.points[3].y = std::numeric_limits<double>::quiet_NaN();
  const std::pair<const HexMesh*, std::string> cases[] = {
      {&bad_index, "hex 5 refers to point 27 but the mesh has 27 points"},
      {&bad_regions, "the mesh has 8 hexes but 7 region labels"},
      {&bad_point, "point 3 has a non-finite coordinate"}};
  for (const auto& c : cases) {
    // Named copies, not a structured binding: clang 14 cannot capture one in a lambda.
    const HexMesh* mesh = c.first;
    const std::string& reason = c.second;
    EXPECT_EQ(input_error([&] { write_hex_mesh(*mesh, path); }), path.string() + ": " + reason);
    EXPECT_EQ(read_bytes(path), "old");
    EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"out.vtu"});
  }
}

TEST(HexmeshWrite, TargetThatIsAFolderIsNotReplaced) {
  TempDir dir;
  const fs::path path = dir / "taken.msh";
  fs::create_directories(path / "inside");
  const std::string message = input_error([&] { write_hex_mesh(sample_mesh(), path); });
  EXPECT_EQ(message.rfind(path.string() + ": cannot move the finished file into place: ", 0), 0u) << message;
  EXPECT_TRUE(fs::is_directory(path / "inside"));
  EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"taken.msh"});
}

TEST(HexmeshWrite, UnknownExtension) {
  TempDir dir;
  EXPECT_EQ(input_error([&] { write_hex_mesh(sample_mesh(), dir / "out.stl"); }),
            (dir / "out.stl").string() + ": unknown mesh format '.stl' (use .mesh, .meshb, .vtu, .msh, .exo or .inp)");
  EXPECT_EQ(input_error([&] { read_hex_mesh(dir / "out.Obj"); }),
            (dir / "out.Obj").string() + ": unknown mesh format '.Obj' (use .mesh, .meshb, .vtu, .msh, .exo or .inp)");
  EXPECT_EQ(input_error([&] { write_hex_mesh(sample_mesh(), dir / "out"); }),
            (dir / "out").string() +
                ": no file extension to tell the mesh format (use .mesh, .meshb, .vtu, .msh, .exo or .inp)");
  EXPECT_TRUE(listing(dir.path()).empty());
  EXPECT_EQ(mesh_format("a/b.MeSh"), MeshFormat::kMedit);
  EXPECT_EQ(mesh_format("b.vtu"), MeshFormat::kVtu);
  EXPECT_EQ(mesh_format("b.msh"), MeshFormat::kGmsh);
  EXPECT_EQ(mesh_format("b.MESHB"), MeshFormat::kMeditBinary);
  EXPECT_EQ(mesh_format("b.exo"), MeshFormat::kExodus);
  EXPECT_EQ(mesh_format("b.Inp"), MeshFormat::kAbaqus);
}

TEST(HexmeshWrite, WrittenTextIsWhatOtherToolsExpect) {
  TempDir dir;
  HexMesh one;
  one.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 0.5}};
  one.hexes = {{0, 1, 2, 3, 4, 5, 6, 7}};
  one.region = {2};
  write_hex_mesh(one, dir / "one.mesh");
  EXPECT_EQ(read_bytes(dir / "one.mesh"), "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n8\n"
                                          "0 0 0 0\n1 0 0 0\n1 1 0 0\n0 1 0 0\n0 0 1 0\n1 0 1 0\n1 1 1 0\n0 1 0.5 0\n"
                                          "\nHexahedra\n1\n1 2 3 4 5 6 7 8 2\n\nEnd\n");
  write_hex_mesh(one, dir / "one.msh");
  EXPECT_EQ(read_bytes(dir / "one.msh"), "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                                         "$PhysicalNames\n1\n3 2 \"region_2\"\n$EndPhysicalNames\n"
                                         "$Entities\n0 0 0 1\n2 0 0 0 1 1 1 1 2 0\n$EndEntities\n"
                                         "$Nodes\n1 8 1 8\n3 2 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n"
                                         "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 0.5\n$EndNodes\n"
                                         "$Elements\n1 1 1 1\n3 2 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n");
}

// ---------------------------------------------------------------------------------------------
// MEDIT

TEST(HexmeshMedit, ReadsFilesOfOtherTools) {
  TempDir dir;
  const HexMesh mesh = read_text(dir, "other.mesh",
                                 "# written by hand\r\n"
                                 "MeshVersionFormatted 1\r\n"
                                 "Dimension\r\n3\r\n"
                                 "Vertices\r\n9\r\n"
                                 "0 0 0 1\r\n1 0 0 1\r\n1 1 0 1\r\n0 1 0 1\r\n"
                                 "0 0 1 1\r\n1 0 1 1\r\n1 1 1 1\r\n0 1 1 1\r\n"
                                 "  +2.5e0   -1E-2  .5 7\r\n"
                                 "# surface and annotation sections are skipped\n"
                                 "Edges 1\n1 2 5\n"
                                 "Triangles\n2\n1 2 3 1\n1 3 4 1\n"
                                 "Quadrilaterals 1 5 6 7 8 4\n"
                                 "Corners 2 1 2\n"
                                 "RequiredVertices 1 3\n"
                                 "Normals 1 0 0 1\n"
                                 "NormalAtVertices 1 1 1\n"
                                 "Tetrahedra 0\n"
                                 "Hexaedra\n1\n1 2 3 4 5 6 7 8 11\n"
                                 "Hexahedra\n1\n1 2 3 4 5 6 7 9 -4\n"
                                 "End\n"
                                 "anything after End is ignored\n");
  ASSERT_EQ(mesh.points.size(), 9u);
  EXPECT_EQ(mesh.points[8], (Vec3{2.5, -0.01, 0.5}));
  EXPECT_EQ(mesh.hexes, (std::vector<Hex>{{0, 1, 2, 3, 4, 5, 6, 7}, {0, 1, 2, 3, 4, 5, 6, 8}}));
  EXPECT_EQ(mesh.region, (std::vector<int32_t>{11, -4}));
}

TEST(HexmeshMedit, HexahedraBeforeVerticesAreCheckedAtTheEnd) {
  TempDir dir;
  const std::string head = "MeshVersionFormatted 2\nDimension 3\nHexahedra\n1\n1 2 3 4 5 6 7 ";
  std::string vertices;
  for (int i = 0; i < 8; ++i) vertices += "0 0 " + std::to_string(i) + " 0\n";
  const HexMesh ok = read_text(dir, "late.mesh", head + "8 0\nVertices\n8\n" + vertices + "End\n");
  EXPECT_EQ(ok.hexes.size(), 1u);
  expect_read_error(dir, "late.mesh", head + "9 0\nVertices\n8\n" + vertices + "End\n",
                    "hexahedron 1 refers to vertex 9 but the file has 8 vertices");
}

TEST(HexmeshMedit, BadFiles) {
  TempDir dir;
  const std::string head = "MeshVersionFormatted 2\nDimension 3\nVertices\n8\n";
  std::string vertices;
  for (int i = 0; i < 8; ++i) vertices += std::to_string(i) + " 0 0 0\n";
  const std::string ok = head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 8 1\nEnd\n";
  ASSERT_EQ(read_text(dir, "ok.mesh", ok).hexes.size(), 1u);

  const std::pair<std::string, std::string> cases[] = {
      {head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 9 1\nEnd\n",
       "line 15: hexahedron vertex index 9 is out of range 1..8"},
      {head + vertices + "Hexahedra\n1\n0 2 3 4 5 6 7 8 1\nEnd\n", "hexahedron vertex index 0 is out of range"},
      {head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 8 5000000000\nEnd\n",
       "line 15: region label 5000000000 does not fit in 32 bits"},
      {head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 8\nEnd\n",
       "expected a hexahedron reference (an integer), found 'End'"},
      {head + vertices + "Hexahedra\n2\n1 2 3 4 5 6 7 8 1\n",
       "line 16: unexpected end of file where a hexahedron vertex index was expected (truncated file?)"},
      {head + vertices + "Hexahedra\n3\n1 2 3 4 5 6 7 8 1\n", "Hexahedra count 3 is more than the rest of the file"},
      {head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 8 1\n", "no End keyword (truncated file?)"},
      {head + vertices + "Hexahedra\n999999999999999\n1 2 3 4 5 6 7 8 1\nEnd\n",
       "Hexahedra count 999999999999999 is more than the rest of the file can hold"},
      {head + vertices + "Hexahedra\n99999999999999999999999\n",
       "Hexahedra count 99999999999999999999999 is out of range"},
      {head + vertices + "Hexahedra\n-1\n", "Hexahedra count -1 is out of range"},
      {head + vertices + "Tetrahedra\n1\n1 2 3 4 1\nEnd\n", "line 14: 1 Tetrahedra: only all-hex meshes can be read"},
      {head + vertices + "Prisms 1 1 2 3 4 5 6 0\nEnd\n", "1 Prisms: only all-hex meshes can be read"},
      {head + vertices + "Hexahedra\n1\n1 2 3 4 5 6 7 8 1\nPolygons 3\nEnd\n", "unknown MEDIT keyword 'Polygons'"},
      {head + "0 0 nan 0\n" + vertices, "line 5: a vertex coordinate 'nan' is not a finite number"},
      {head + "0 0 -inf 0\n" + vertices, "a vertex coordinate '-inf' is not a finite number"},
      {head + "0 0 1e999 0\n" + vertices, "a vertex coordinate '1e999' is not a finite number"},
      {head + "0 0 0x10 0\n" + vertices, "expected a vertex coordinate (a number), found '0x10'"},
      {head + "0 0 1,5 0\n" + vertices, "expected a vertex coordinate (a number), found '1,5'"},
      {"MeshVersionFormatted 2\nDimension 2\nVertices\n1\n0 0 0\nEnd\n", "Dimension 2: only 3D meshes are supported"},
      {"MeshVersionFormatted 2\nVertices\n1\n0 0 0 0\nEnd\n", "Vertices before 'Dimension 3'"},
      {"MeshVersionFormatted 9\n", "unknown MeshVersionFormatted 9"},
      {head + vertices + "Vertices\n0\nEnd\n", "a second Vertices section"},
      {"", "line 1: no End keyword"},
      {"solid cube\nfacet normal 0 0 1\n", "line 1: unknown MEDIT keyword 'solid'"},
      {std::string("\x89PNG\r\n\x1a\n\0\0\0", 11), "unknown MEDIT keyword '?PNG'"},
  };
  for (const auto& [content, reason] : cases) expect_read_error(dir, "bad.mesh", content, reason);
}

// ---------------------------------------------------------------------------------------------
// Gmsh

TEST(HexmeshGmsh, ReadsFilesOfOtherTools) {
  TempDir dir;
  // Node tags sparse, unordered and split over blocks (one parametric), lower-dimension elements
  // of several types, hexes with unordered element tags, unknown sections.
  const HexMesh mesh = read_text(dir, "other.msh",
                                 "$Comments\nmade by hand\n$EndComments\n"
                                 "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                                 "$PhysicalNames\n2\n2 10 \"wall with spaces\"\n3 42 \"solid\"\n$EndPhysicalNames\n"
                                 "$Entities\n1 0 1 2\n"
                                 "7 0 0 0 0\n"
                                 "3 0 0 0 1 1 1 1 10 0\n"
                                 "5 0 0 0 1 1 1 2 42 43 1 3\n"
                                 "6 0 0 0 1 1 1 0 0\n"
                                 "$EndEntities\n"
                                 "$Nodes\n2 9 2 90\n"
                                 "3 5 0 5\n90\n20\n30\n40\n50\n"
                                 "1 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n"
                                 "2 3 1 4\n60\n70\n80\n2\n"
                                 "1 1 1 0.5 0.5\n0 1 1 0 0\n2.5 -1e-2 .5 1 1\n0 0 0 0.25 0.75\n"
                                 "$EndNodes\n"
                                 "$Elements\n5 4 1 400\n"
                                 "0 7 15 1\n100 2\n"
                                 "3 5 5 1\n300 2 20 30 40 50 60 70 80\n"
                                 "2 3 3 1\n1 2 20 30 40\n"
                                 "1 9 1 0\n"
                                 "3 6 5 1\n200 2 20 30 40 50 60 70 90\n"
                                 "$EndElements\n"
                                 "$NodeData\n1\n\"T\"\n$EndNodeData\n");
  ASSERT_EQ(mesh.points.size(), 9u);
  // Points in tag order: 2 20 30 40 50 60 70 80 90.
  EXPECT_EQ(mesh.points[0], (Vec3{0, 0, 0}));
  EXPECT_EQ(mesh.points[1], (Vec3{1, 0, 0}));
  EXPECT_EQ(mesh.points[7], (Vec3{2.5, -0.01, 0.5}));
  EXPECT_EQ(mesh.points[8], (Vec3{1, 0, 0}));
  // Hexes in element tag order: 200 (entity 6, no physical tag) before 300 (entity 5, physical 42).
  EXPECT_EQ(mesh.hexes, (std::vector<Hex>{{0, 1, 2, 3, 4, 5, 6, 8}, {0, 1, 2, 3, 4, 5, 6, 7}}));
  EXPECT_EQ(mesh.region, (std::vector<int32_t>{6, 42}));
}

TEST(HexmeshGmsh, WithoutEntitiesTheEntityTagIsTheRegion) {
  TempDir dir;
  const HexMesh mesh = read_text(dir, "plain.msh",
                                 "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                                 "$Nodes\n1 8 1 8\n3 0 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n"
                                 "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n"
                                 "$Elements\n1 1 1 1\n3 4 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n");
  EXPECT_EQ(mesh.region, std::vector<int32_t>{4});
}

TEST(HexmeshGmsh, BadFiles) {
  TempDir dir;
  const std::string format = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  const std::string nodes = "$Nodes\n1 8 1 8\n3 1 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n"
                            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n";
  const std::string hexes = "$Elements\n1 1 1 1\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n";
  ASSERT_EQ(read_text(dir, "ok.msh", format + nodes + hexes).hexes.size(), 1u);

  const std::pair<std::string, std::string> cases[] = {
      // The literal ends at the first NUL: the byte-order int is cut short.
      {"$MeshFormat\n4.1 1 8\n\x01\0\0\0\n$EndMeshFormat\n",
       "byte 20: unexpected end of file where the byte-order int"},
      {"$MeshFormat\n4.1 1 4\n", "binary data size 4: only 8-byte size_t is supported"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n", "Gmsh format version 2.2 is not supported"},
      {"$Nodes\n0 0 0 0\n$EndNodes\n", "line 1: the file does not start with $MeshFormat"},
      {"hello\n", "line 1: expected a section header such as $Nodes, found 'hello'"},
      {format + nodes, "no $Elements section"},
      {format + hexes, "$Elements before $Nodes"},
      {format + nodes + "$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 4\n$EndElements\n",
       "volume entity 1 holds elements of type 4: only 8-node hexahedra (type 5) can be read"},
      {format + nodes + "$Elements\n1 1 1 1\n3 1 5 1\n1 1 2 3 4 5 6 7 9\n$EndElements\n",
       "line 27: element 1 uses node 9, which $Nodes does not define"},
      {format + nodes + "$Elements\n1 2 1 2\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n",
       "the element blocks hold 1 elements, not the 2 announced"},
      {format + nodes + "$Elements\n1 1 1 1\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n9 1 2 3 4 5 6 7 8\n$EndElements\n",
       "expected '$EndElements', found '9'"},
      {format + nodes + "$Elements\n2 2 1 2\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n",
       "element tag 1 is used twice"},
      {format + "$Nodes\n1 2 1 2\n3 1 0 2\n1\n1\n0 0 0\n1 1 1\n$EndNodes\n" + hexes, "node tag 1 is used twice"},
      {format + "$Nodes\n1 1 1 1\n3 1 0 1\n1\n0 nan 0\n$EndNodes\n",
       "line 8: a node coordinate 'nan' is not a finite number"},
      {format + "$Nodes\n1 99999999999 1 1\n", "node count 99999999999 is more than the rest of the file can hold"},
      {format + "$Nodes\n1 8 1 8\n3 1 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n0 0 0\n",
       "line 5: node count 8 is more than the rest"},
      {format + "$Nodes\n1 2 1 2\n3 1 0 2\n1\n2\n0 0 0\n1 1",
       "unexpected end of file where a node coordinate was expected"},
      {format + nodes + "$Elements\n1 1 1 1\n2 1 3 1\n", "unexpected end of file where an element was expected"},
      {format + "$Foo\n1 2 3\n", "unexpected end of file where '$EndFoo' was expected"},
      // A damaged section name reaches the message escaped: one line of valid UTF-8 (a byte that
      // begins no UTF-8 sequence, a cut-short sequence, a control byte; an intact one stays).
      {format + "$N\xa9"
                "d\xe2\x01\xc3\xa9s\n1 2 3\n",
       "unexpected end of file where '$EndN\\xa9d\\xe2\\x01\xc3\xa9s' was expected"},
      {format + "$EndNodes\n", "'$EndNodes' without its opening section"},
      {format + nodes + "$Elements\n1 1 1 1\n4 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n",
       "entity dimension 4 is not 0..3"},
  };
  for (const auto& [content, reason] : cases) expect_read_error(dir, "bad.msh", content, reason);
}

// ---------------------------------------------------------------------------------------------
// VTU

std::string base64(std::string_view bytes) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t bits = static_cast<uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) bits |= static_cast<uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) bits |= static_cast<uint8_t>(bytes[i + 2]);
    out += kDigits[(bits >> 18) & 63];
    out += kDigits[(bits >> 12) & 63];
    out += i + 1 < bytes.size() ? kDigits[(bits >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[bits & 63] : '=';
  }
  return out;
}

template <class T>
std::string packed(const std::vector<T>& values, bool big_endian) {
  std::string out;
  for (const T v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

// One DataArray in the encodings that VTK and meshio use for inline data.
enum class Encoding { kAscii, kBinaryJoint, kBinarySplit };

template <class T>
std::string data_array(const std::string& type, const std::string& name, const std::vector<T>& values,
                       Encoding encoding, bool big_endian = false, int components = 1) {
  std::string head = "<DataArray type=\"" + type + "\" Name=\"" + name + "\"" +
                     (components != 1 ? " NumberOfComponents=\"" + std::to_string(components) + "\"" : "");
  if (encoding == Encoding::kAscii) {
    std::ostringstream s;
    s.precision(17);
    for (const T v : values) s << +v << "\n ";
    return head + " format=\"ascii\">\n " + s.str() + "</DataArray>\n";
  }
  const std::string data = packed(values, big_endian);
  const std::string header = packed(std::vector<uint32_t>{static_cast<uint32_t>(data.size())}, big_endian);
  const std::string text = encoding == Encoding::kBinaryJoint ? base64(header + data) : base64(header) + base64(data);
  return head + " format=\"binary\">\n" + text + "\n</DataArray>\n";
}

std::string vtu_file(std::size_t points, std::size_t cells, const std::string& arrays_points,
                     const std::string& arrays_cells, const std::string& arrays_cell_data, bool big_endian = false) {
  return std::string("<?xml version=\"1.0\"?>\n<!-- a comment -->\n") +
         "<VTKFile type='UnstructuredGrid' version='0.1' byte_order='" + (big_endian ? "BigEndian" : "LittleEndian") +
         "'>\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"" + std::to_string(points) + "\" NumberOfCells=\"" +
         std::to_string(cells) + "\">\n<PointData></PointData>\n<Points>\n" + arrays_points + "</Points>\n<Cells>\n" +
         arrays_cells + "</Cells>\n<CellData>\n" + arrays_cell_data +
         "</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
}

TEST(HexmeshVtu, ReadsInlineAsciiAndBase64InEitherByteOrder) {
  TempDir dir;
  const HexMesh mesh = sample_mesh();
  std::vector<double> xyz;
  for (const Vec3& p : mesh.points) xyz.insert(xyz.end(), {p.x, p.y, p.z});
  // A quad (VTK type 9) in the middle, which the reader skips along with its label.
  std::vector<int64_t> connectivity, offsets, types, labels;
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h) {
    if (h == 3) {
      connectivity.insert(connectivity.end(), {0, 1, 2, 3});
      offsets.push_back(static_cast<int64_t>(connectivity.size()));
      types.push_back(9);
      labels.push_back(99);
    }
    connectivity.insert(connectivity.end(), mesh.hexes[h].begin(), mesh.hexes[h].end());
    offsets.push_back(static_cast<int64_t>(connectivity.size()));
    types.push_back(12);
    labels.push_back(mesh.region[h]);
  }
  const std::vector<uint8_t> types8(types.begin(), types.end());
  const std::vector<int32_t> labels32(labels.begin(), labels.end());
  for (const Encoding encoding : {Encoding::kAscii, Encoding::kBinaryJoint, Encoding::kBinarySplit})
    for (const bool big : {false, true}) {
      SCOPED_TRACE("encoding " + std::to_string(static_cast<int>(encoding)) + (big ? " big endian" : ""));
      const std::string text =
          vtu_file(mesh.points.size(), types.size(), data_array("Float64", "Points", xyz, encoding, big, 3),
                   data_array("Int64", "connectivity", connectivity, encoding, big) +
                       data_array("Int64", "offsets", offsets, encoding, big) +
                       data_array("UInt8", "types", types8, encoding, big),
                   data_array("Int32", "other", labels32, encoding, big) +
                       data_array("Int32", "region", labels32, encoding, big),
                   big);
      expect_same_mesh(mesh, read_text(dir, "inline.vtu", text));
    }
}

TEST(HexmeshVtu, MissingRegionArrayReadsAsZero) {
  TempDir dir;
  const HexMesh mesh = sample_mesh();
  std::vector<double> xyz;
  for (const Vec3& p : mesh.points) xyz.insert(xyz.end(), {p.x, p.y, p.z});
  std::vector<int32_t> connectivity, offsets, types;
  for (const Hex& h : mesh.hexes) {
    connectivity.insert(connectivity.end(), h.begin(), h.end());
    offsets.push_back(static_cast<int32_t>(connectivity.size()));
    types.push_back(12);
  }
  const std::string text = vtu_file(mesh.points.size(), mesh.hexes.size(),
                                    data_array("Float64", "Points", xyz, Encoding::kBinaryJoint, false, 3),
                                    data_array("Int32", "connectivity", connectivity, Encoding::kAscii) +
                                        data_array("Int32", "offsets", offsets, Encoding::kAscii) +
                                        data_array("Int32", "types", types, Encoding::kAscii),
                                    "");
  const HexMesh got = read_text(dir, "unlabelled.vtu", text);
  EXPECT_EQ(got.hexes, mesh.hexes);
  EXPECT_EQ(got.region, std::vector<int32_t>(mesh.hexes.size(), 0));
}

// Found by fuzz_read_mesh (.ci/sanitize.sh): a processing instruction cut off at its start put
// the file's own newline into the one-line message.
TEST(HexmeshVtu, UnterminatedProcessingInstructionIsOneLine) {
  TempDir dir;
  expect_read_error(dir, "cut.vtu", "<?xml version=\"1.0\"?>\n<?>\n<VTKFile", "XML: unterminated '<?>?'");
}

// The pipeline has each hex's scaled Jacobian from its check and may hand them to the writer; the
// file is the one the writer makes computing them itself.
TEST(HexmeshVtu, GivenScaledJacobiansGiveTheSameFile) {
  TempDir dir;
  HexMesh mesh = grid_mesh(12);
  // Warped, so that the quality's shortcut for parallelepipeds is not the only path taken.
  for (Vec3& p : mesh.points) p += Vec3{0.05 * std::sin(5 * p.y), 0.04 * std::sin(3 * p.z + p.x), 1e-4 * std::sin(p.x)};
  std::vector<double> quality;
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h) quality.push_back(hex_quality(mesh.corners(h)).scaled_jacobian);
  write_hex_mesh(mesh, dir / "computed.vtu");
  MeshWriteOptions options;
  options.scaled_jacobians = quality;
  write_hex_mesh(mesh, dir / "given.vtu", options);
  EXPECT_EQ(read_bytes(dir / "computed.vtu"), read_bytes(dir / "given.vtu"));
  quality.pop_back();
  options.scaled_jacobians = quality;
  const fs::path path = dir / "short.vtu";
  EXPECT_EQ(input_error([&] { write_hex_mesh(mesh, path, options); }),
            path.string() + ": 1727 scaled Jacobians given for 1728 hexes");
  EXPECT_FALSE(fs::exists(path));
}

TEST(HexmeshVtu, BadFiles) {
  TempDir dir;
  write_hex_mesh(sample_mesh(), dir / "good.vtu");
  const std::string good = read_bytes(dir / "good.vtu");
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const std::size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  // The raw block header of the points array sits right after the '_'.
  std::string huge_block = good;
  const std::size_t data = huge_block.find('_', huge_block.find("<AppendedData")) + 1;
  huge_block[data + 6] = '\x7f';

  const std::pair<std::string, std::string> cases[] = {
      {replaced("byte_order=", "compressor=\"vtkZLibDataCompressor\" byte_order="),
       "VTU: compressed data (vtkZLibDataCompressor) is not supported"},
      {replaced("type=\"UnstructuredGrid\"", "type=\"PolyData\""), "VTK file type 'PolyData' is not supported"},
      {replaced("offset=\"0\"", "offset=\"9999999\""),
       "DataArray 'Points': offset 9999999 is past the end of the file"},
      {replaced("NumberOfPoints=\"27\"", "NumberOfPoints=\"26\""),
       "DataArray 'Points' holds 648 bytes where 624 are expected"},
      {replaced("NumberOfPoints=\"27\"", "NumberOfPoints=\"99999999999999999\""),
       "points are more than 32-bit indices can address"},
      {replaced("NumberOfCells=\"8\"", "NumberOfCells=\"99999999\""),
       "DataArray 'offsets': 99999999 values cannot fit in this file"},
      {replaced("NumberOfCells=\"8\"", "NumberOfCells=\"x\""), "<Piece> has no valid NumberOfCells"},
      {replaced("Name=\"types\"", "Name=\"kinds\""), "no DataArray 'types' in <Cells>"},
      {replaced("<Points>", "<Points></Points><Points>"), "more than one <Points>"},
      {replaced("</Piece>", "</Piece><Piece NumberOfPoints=\"0\" NumberOfCells=\"0\"></Piece>"),
       "more than one <Piece>: only single-piece files can be read"},
      {replaced("type=\"UInt8\"", "type=\"Float32\""),
       "DataArray 'types' holds floating-point values where integers are expected"},
      {replaced("type=\"UInt8\"", "type=\"Int128\""), "DataArray 'types' has unknown type 'Int128'"},
      {replaced("encoding=\"raw\"", "encoding=\"zip\""), "unknown AppendedData encoding 'zip'"},
      {replaced("</Cells>", "</Cell>"), "XML: unexpected </Cell>"},
      {huge_block, "DataArray 'Points' holds"},
      {"<?xml version=\"1.0\"?>\n", "XML: no XML element found"},
      {"<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid>", "XML: unexpected end of file (truncated file?)"},
      {"<VTKFile type=\"UnstructuredGrid\" version=1.0>", "XML: unquoted attribute 'version'"},
      {"solid cube\n", "XML: no XML element found"},
  };
  for (const auto& [content, reason] : cases) expect_read_error(dir, "bad.vtu", content, reason);

  std::vector<double> xyz(24, 0.0);
  const std::vector<int64_t> tetra = {0, 1, 2, 3}, offsets = {4}, types = {10};
  expect_read_error(dir, "tetra.vtu",
                    vtu_file(8, 1, data_array("Float64", "Points", xyz, Encoding::kAscii, false, 3),
                             data_array("Int64", "connectivity", tetra, Encoding::kAscii) +
                                 data_array("Int64", "offsets", offsets, Encoding::kAscii) +
                                 data_array("Int64", "types", types, Encoding::kAscii),
                             ""),
                    "cell 0 has VTK type 10: only hexahedra (12) and cells of dimension < 3 can be read");
  xyz[5] = std::numeric_limits<double>::infinity();
  expect_read_error(dir, "inf.vtu",
                    vtu_file(8, 0, data_array("Float64", "Points", xyz, Encoding::kBinarySplit, false, 3), "", ""),
                    "point 1 has a non-finite coordinate");
}

// ---------------------------------------------------------------------------------------------
// Files for and from meshio (driven by tests/test_meshio_formats.py)

TEST(HexmeshSamples, WriteSamples) {
  const char* out = std::getenv("MCHEX_MESHIO_OUT");
  TempDir own;
  const fs::path dir = out != nullptr ? fs::path(out) : own.path();
  for (const char* ext : {".mesh", ".vtu", ".msh", ".meshb", ".exo", ".inp"}) {
    write_hex_mesh(sample_mesh(), dir / (std::string("sample") + ext));
    EXPECT_TRUE(fs::is_regular_file(dir / (std::string("sample") + ext)));
  }
  MeshWriteOptions binary;
  binary.binary = true;
  write_hex_mesh(sample_mesh(), dir / "sample_binary.msh", binary);
}

}  // namespace
}  // namespace mchex
