// Build-time generator of the tables that device code reads: the one source of truth is core/
// (constexpr tables of core/cutting/mc33.h, core/mesh/hex_faces.h and core/cutting/local_refinement.h, the layouts of
// core/sdf/bvh.h and core/device/device_scene.h); this program prints them as an OpenCL C header and a GLSL header with
// the same names, so kernels/*.h (shared by kernels/*.cl and shaders/*.comp) read one set of
// names in either dialect. No table is typed by hand in device code.
//
// Usage: gen_device_tables OUT_DIR   (writes OUT_DIR/mchex_tables.cl.h and mchex_tables.glsl.h)
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/device/cell_words.h"
#include "core/device/device_scene.h"
#include "core/grid/refinement_error.h"
#include "core/mesh/hex_faces.h"
#include "core/sdf/bvh.h"
#include "core/sdf/shapes.h"

namespace {

using namespace mchex;

static_assert(offsetof(BvhNode, lo) == 0 && offsetof(BvhNode, index) == 12 && offsetof(BvhNode, hi) == 16 &&
                  offsetof(BvhNode, count) == 28,
              "BvhNode's device declaration below assumes this layout (std430 and OpenCL agree on it)");

struct Table {
  std::string name, comment;
  std::vector<int> values;
};

std::vector<Table> tables() {
  std::vector<Table> t;
  auto add = [&](std::string name, std::string comment) -> std::vector<int>& {
    t.push_back({std::move(name), std::move(comment), {}});
    return t.back().values;
  };
  {
    auto& v = add("kCubeCorners", "core/cutting/mc33.h kCubeCorners: corner c is (x, y, z) = [3c .. 3c+2]");
    for (const auto& c : kCubeCorners) v.insert(v.end(), c.begin(), c.end());
  }
  {
    auto& v =
        add("kCubeEdges", "core/cutting/mc33.h kCubeEdges (paper Table 1): edge e runs from corner [2e] to [2e+1]");
    for (const auto& e : kCubeEdges) v.insert(v.end(), e.begin(), e.end());
  }
  {
    auto& v = add("kHexFaces", "core/mesh/hex_faces.h kHexFaces: face f has corners [4f .. 4f+3], cyclic");
    for (const auto& f : kHexFaces) v.insert(v.end(), f.begin(), f.end());
  }
  {
    auto& v = add("kEdgeNeighbours", "bit mask of the corners that share a cube edge with corner c");
    v.assign(8, 0);
    for (const auto& e : kCubeEdges) v[e[0]] |= 1 << e[1], v[e[1]] |= 1 << e[0];
  }
  {
    // What the mesher makes of a cell, so the device's prefix sum is the real output count:
    // 8 + 2 * cut edges for a cell cut directly, the sum over the leaves for one refined locally
    // (paper Section 5, Figure 7), a function of the subcase alone.
    auto& h = add("kSubcaseHexes", "core/cutting/local_refinement.h local_refinement_hexes(s): hexes the mesher makes");
    for (int s = 0; s < kNumSubcases; ++s) h.push_back(local_refinement_hexes(Subcase(s)));
  }
  {
    auto& corner = add("kSymmetryCorner", "core/cutting/mc33.h kCubeSymmetries[g].corner[c] at [8g + c]");
    for (const auto& g : kCubeSymmetries) corner.insert(corner.end(), g.corner.begin(), g.corner.end());
    auto& edge = add("kSymmetryEdge", "kCubeSymmetries[g].edge[e] at [12g + e]");
    for (const auto& g : kCubeSymmetries) edge.insert(edge.end(), g.edge.begin(), g.edge.end());
    auto& rev = add("kSymmetryEdgeReversed", "kCubeSymmetries[g].edge_reversed (bit e: s becomes 1 - s)");
    for (const auto& g : kCubeSymmetries) rev.push_back(g.edge_reversed);
    auto& face = add("kSymmetryFace", "kCubeSymmetries[g].face[f] at [6g + f]");
    for (const auto& g : kCubeSymmetries) face.insert(face.end(), g.face.begin(), g.face.end());
    auto& inv = add("kSymmetryInverse", "kCubeSymmetries[g].inverse");
    for (const auto& g : kCubeSymmetries) inv.push_back(g.inverse);
    auto& refl = add("kSymmetryReflection", "kCubeSymmetries[g].reflection");
    for (const auto& g : kCubeSymmetries) refl.push_back(g.reflection);
  }
  return t;
}

struct Define {
  std::string name;
  long long value;
  std::string comment;
};

std::vector<Define> defines() {
  return {
      {"MCHEX_NUM_CUBE_SYMMETRIES", kNumCubeSymmetries, ""},
      {"MCHEX_NUM_CUBE_ROTATIONS", kNumCubeRotations, "symmetries 0..23 are rotations"},
      {"MCHEX_NUM_SUBCASES", kNumSubcases, "kEmpty (0) and the 31 MC33 subcases, core/cutting/mc33.h order"},
      {"MCHEX_NO_SYMMETRY", kNoCubeSymmetry, "core/cutting/mc33.h kNoCubeSymmetry"},
      {"MCHEX_CONFIG_WORDS", kConfigWords, "packed mc33_config() words, buffer index mask * 64 + face_joins"},
      {"MCHEX_CONFIG_MAP0_SHIFT", kConfigMap0Shift, "core/device/device_scene.h packed_mc33_configs()"},
      {"MCHEX_CONFIG_MAP1_SHIFT", kConfigMap1Shift, ""},
      {"MCHEX_CONFIG_PREFERRED_SHIFT", kConfigPreferredShift, ""},
      {"MCHEX_CONFIG_SUBCASE_BASE", kConfigSubcaseBase,
       "then one word per subcase: partner | (tunnel + 1) << 8 | hexes << 16"},
      {"MCHEX_CONFIG_TUNNEL_SHIFT", kConfigTunnelShift, ""},
      {"MCHEX_CONFIG_HEXES_SHIFT", kConfigHexesShift, ""},
      {"MCHEX_CODE_SIGN_SHIFT", kCodeSignShift, "core/device/device_scene.h: CellCode word 0"},
      {"MCHEX_CODE_FACE_SHIFT", kCodeFaceShift, ""},
      {"MCHEX_CODE_TUNNEL_SHIFT", kCodeTunnelShift, "stores tunnel + 1"},
      {"MCHEX_CODE_INVERTED_SHIFT", kCodeInvertedShift, ""},
      {"MCHEX_CODE_CUT_SHIFT", kCodeCutShift, "CellCode word 1: symmetry | cut_edges << shift"},
      {"MCHEX_CHILD_LATTICE_POINTS", kChildLatticePoints, "core/grid/refinement_error.h"},
      {"MCHEX_SLOT_CORNER_DOUBLES", 9, "core/device/device_scene.h slot_corners per slot"},
      {"MCHEX_SLOT_FEATURE_WORDS", 6, "core/device/device_scene.h slot_features per slot"},
      {"MCHEX_FP32_CANDIDATES", kFp32Candidates,
       "core/device/device_scene.h: candidate slots per point, kernels/sdf_fp32.h"},
      {"MCHEX_WIDE_NODE_FLOAT4S", kWideNodeFloats / 4,
       "core/device/device_scene.h wide_boxes per node, in float4 groups"},
      {"MCHEX_WIDE_NODE_LINKS", kWideNodeLinks, "core/device/device_scene.h wide_links per node"},
      {"MCHEX_LEAF_BOUND_FLOAT4S", kLeafBoundFloats / 4,
       "core/device/device_scene.h leaf_bounds per leaf, in float4 groups"},
      {"MCHEX_SDF_WIDE_STACK", kSdfWideStack, "core/device/device_scene.h: entries of kernels/sdf.h's walk stack"},
  };
}

// core/sdf/shapes.h dimensions, printed so that they read back as the same doubles.
std::vector<std::pair<std::string, double>> shape_constants() {
  using namespace shape_dimensions;
  return {
      {"MCHEX_SPHERE_RADIUS", kSphereRadius}, {"MCHEX_TORUS_MAJOR", kTorusMajor}, {"MCHEX_TORUS_MINOR", kTorusMinor},
      {"MCHEX_BOX_HALF_X", kBoxHalf.x},       {"MCHEX_BOX_HALF_Y", kBoxHalf.y},   {"MCHEX_BOX_HALF_Z", kBoxHalf.z},
      {"MCHEX_BOX_ROUNDING", kBoxRounding},   {"MCHEX_EIGHT_RING", kEightRing},   {"MCHEX_EIGHT_TUBE", kEightTube}};
}

// A double literal that parses back to v: 17 significant digits; GLSL needs the lf suffix (an
// unsuffixed literal is a float there).
std::string double_literal(double v, bool glsl) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s = buf;
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return glsl ? s + "lf" : s;
}

std::string constants(bool glsl) {
  std::string s;
  for (const auto& d : defines())
    s += "#define " + d.name + " " + std::to_string(d.value) + (d.comment.empty() ? "" : "  // " + d.comment) + "\n";
  // kernels/classify.h's filter in front of the exact face test: 2^-50 = 8 u (u = 2^-53).
  s += "#define MCHEX_DET_FILTER " + double_literal(std::ldexp(1.0, -50), glsl) + "\n";
  s += "// core/sdf/shapes.h shape_dimensions\n";
  for (const auto& [name, v] : shape_constants()) s += "#define " + name + " " + double_literal(v, glsl) + "\n";
  return s;
}

std::string header(const char* dialect) {
  std::ostringstream o;
  o << "// GENERATED by host/backends/gen_device_tables.cpp from core/ at build time (" << dialect
    << "). Do not edit: change core/ and rebuild.\n";
  return o.str();
}

std::string list(const std::vector<int>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? (i % 16 ? ", " : ",\n    ") : "") + std::to_string(v[i]);
  return s;
}

std::string opencl() {
  std::ostringstream o;
  o << header("OpenCL C 1.2") << "#ifndef MCHEX_TABLES_H\n#define MCHEX_TABLES_H\n\n";
  o << constants(false);
  o << "\n// core/sdf/bvh.h BvhNode (32 bytes)\ntypedef struct BvhNode {\n  float lo[3];\n  uint index;\n  float hi[3];\n"
       "  uint count;\n} BvhNode;\n\n";
  for (const auto& t : tables())
    o << "// " << t.comment << "\n__constant int " << t.name << "[" << t.values.size() << "] = {\n    "
      << list(t.values) << "};\n";
  o << "\n#endif\n";
  return o.str();
}

std::string glsl() {
  std::ostringstream o;
  o << header("GLSL 4.50") << "#ifndef MCHEX_TABLES_H\n#define MCHEX_TABLES_H\n\n";
  o << constants(true);
  o << "\n// core/sdf/bvh.h BvhNode (32 bytes in std430)\nstruct BvhNode {\n  float lo[3];\n  uint index;\n  float hi[3];\n"
       "  uint count;\n};\n\n";
  for (const auto& t : tables())
    o << "// " << t.comment << "\nconst int " << t.name << "[" << t.values.size() << "] = int[" << t.values.size()
      << "](\n    " << list(t.values) << ");\n";
  o << "\n#endif\n";
  return o.str();
}

// Writes only when the content changes, so an unchanged table does not rebuild its dependants.
bool write_if_changed(const std::string& path, const std::string& text) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::ostringstream old;
      old << in.rdbuf();
      if (old.str() == text) return true;
    }
  }
  std::ofstream out(path, std::ios::binary);
  out << text;
  return bool(out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: gen_device_tables OUT_DIR\n");
    return 1;
  }
  const std::string dir = argv[1];
  for (const auto& [name, text] :
       {std::pair{"/mchex_tables.cl.h", opencl()}, std::pair{"/mchex_tables.glsl.h", glsl()}})
    if (!write_if_changed(dir + name, text)) {
      std::fprintf(stderr, "gen_device_tables: cannot write %s%s\n", dir.c_str(), name);
      return 1;
    }
  return 0;
}
