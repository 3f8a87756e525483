// MEDIT .mesh (ascii), the format of Gmsh's and libMeshb's INRIA tools; mesh_io.h states the
// contract.
//
// Written: "MeshVersionFormatted 2", "Dimension 3", Vertices with reference 0, and Hexahedra in
// HexMesh corner order (MEDIT's hexahedron numbering is VTK_HEXAHEDRON's) with the region as the
// element reference. Read: free-form tokens with '#' comments, every keyword of libMeshb's table
// that may sit beside hexahedra skipped by its record size, so that a file from another tool is
// read as far as it holds an all-hex mesh; another volume element is an error, not a silent drop.
#include <algorithm>
#include <cstdint>
#include <iterator>
#include <string>
#include <string_view>

#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/record_writer.h"
#include "core/io/scanner.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

// Sections that may sit beside the hexahedra. Record sizes are those of libMeshb's keyword table
// (tokens per record in ascii: fixed ones plus per_dim per space dimension).
struct MeditSection {
  std::string_view name;
  int fixed;
  int per_dim;
  bool volume;   // another kind of volume element: the file is not an all-hex mesh
  bool counted;  // the section starts with its number of records
};
constexpr MeditSection kMeditSections[] = {
    {"Edges", 3, 0, false, true},
    {"Triangles", 4, 0, false, true},
    {"Quadrilaterals", 5, 0, false, true},
    {"EdgesP2", 4, 0, false, true},
    {"TrianglesP2", 7, 0, false, true},
    {"QuadrilateralsQ2", 10, 0, false, true},
    {"Corners", 1, 0, false, true},
    {"Ridges", 1, 0, false, true},
    {"RequiredVertices", 1, 0, false, true},
    {"RequiredEdges", 1, 0, false, true},
    {"RequiredTriangles", 1, 0, false, true},
    {"RequiredQuadrilaterals", 1, 0, false, true},
    {"TangentAtEdgeVertices", 3, 0, false, true},
    {"NormalAtVertices", 2, 0, false, true},
    {"NormalAtTriangleVertices", 3, 0, false, true},
    {"NormalAtQuadrilateralVertices", 4, 0, false, true},
    {"TangentAtVertices", 2, 0, false, true},
    {"Normals", 0, 1, false, true},
    {"Tangents", 0, 1, false, true},
    {"SubDomainFromGeom", 3, 0, false, true},
    {"BoundingBox", 0, 2, false, false},
    {"Tetrahedra", 5, 0, true, true},
    {"TetrahedraP2", 11, 0, true, true},
    {"Prisms", 7, 0, true, true},
    {"Pentahedra", 7, 0, true, true},
    {"Pyramids", 6, 0, true, true},
    {"HexahedraQ2", 28, 0, true, true},
};

}  // namespace

void write_medit(const HexMesh& mesh, AtomicFile& out) {
  std::string head = "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n";
  put_number(head, mesh.points.size());
  head += '\n';
  out.write(head);
  write_points_text(out, mesh.points, " 0\n");
  if (!mesh.hexes.empty()) {
    std::string section = "\nHexahedra\n";
    put_number(section, mesh.hexes.size());
    section += '\n';
    out.write(section);
    // Eight 1-based indices (at most 10 digits: 32-bit indices) and the reference (11 characters).
    write_records(out, mesh.hexes.size(), 8 * 11 + 12, [&](std::size_t begin, std::size_t end, char* p) {
      for (std::size_t h = begin; h < end; ++h) {
        for (const uint32_t v : mesh.hexes[h]) {
          p = put_decimal(p, std::uint64_t{v} + 1);
          *p++ = ' ';
        }
        p = put_decimal(p, mesh.region[h]);
        *p++ = '\n';
      }
      return p;
    });
  }
  out.write("\nEnd\n");
}

HexMesh read_medit(std::string_view text) {
  Scanner in(text, text, /*hash_comments=*/true);
  HexMesh mesh;
  std::int64_t dim = 0;
  bool have_vertices = false;
  for (;;) {
    const std::string_view word = in.next();
    if (word.empty()) in.fail("no End keyword (truncated file?)");
    if (word == "End") break;
    if (word == "MeshVersionFormatted") {
      const auto version = in.integer<std::int64_t>("the MeshVersionFormatted value");
      if (version < 1 || version > 4) in.fail("unknown MeshVersionFormatted " + std::to_string(version));
    } else if (word == "Dimension") {
      dim = in.integer<std::int64_t>("the Dimension value");
      if (dim != 3) in.fail("Dimension " + std::to_string(dim) + ": only 3D meshes are supported");
    } else if (word == "Vertices") {
      if (dim != 3) in.fail("Vertices before 'Dimension 3'");
      if (have_vertices) in.fail("a second Vertices section");
      have_vertices = true;
      const std::uint64_t n = in.count("Vertices", 4);
      if (n > kMaxPoints) in.fail(std::to_string(n) + " vertices are more than 32-bit indices can address");
      mesh.points.resize(n);
      for (Vec3& p : mesh.points) {
        p.x = in.real("a vertex coordinate");
        p.y = in.real("a vertex coordinate");
        p.z = in.real("a vertex coordinate");
        in.integer<std::int64_t>("a vertex reference");
      }
    } else if (word == "Hexahedra" || word == "Hexaedra") {
      const std::uint64_t n = in.count(word, 9);
      const std::size_t first = mesh.hexes.size();
      mesh.hexes.resize(first + n);
      mesh.region.resize(first + n);
      for (std::size_t h = first; h < mesh.hexes.size(); ++h) {
        for (uint32_t& v : mesh.hexes[h]) {
          const auto index = in.integer<std::uint64_t>("a hexahedron vertex index");
          // Vertices normally come first; otherwise the range is checked at the end.
          if (index == 0 || index > (have_vertices ? mesh.points.size() : kMaxPoints))
            in.fail("hexahedron vertex index " + std::to_string(index) + " is out of range" +
                    (have_vertices ? " 1.." + std::to_string(mesh.points.size()) : std::string()));
          v = static_cast<uint32_t>(index - 1);
        }
        mesh.region[h] = to_region(in.integer<std::int64_t>("a hexahedron reference"), in);
      }
    } else {
      const auto* section = std::find_if(std::begin(kMeditSections), std::end(kMeditSections),
                                         [&](const MeditSection& s) { return s.name == word; });
      if (section == std::end(kMeditSections)) in.fail("unknown MEDIT keyword '" + shown(word) + "'");
      if (section->per_dim != 0 && dim == 0) in.fail(std::string(word) + " before Dimension");
      const std::uint64_t tokens = static_cast<std::uint64_t>(section->fixed + section->per_dim * dim);
      const std::uint64_t n = section->counted ? in.count(word, tokens) : 1;
      if (section->volume && n > 0)
        in.fail(std::to_string(n) + " " + std::string(word) + ": only all-hex meshes can be read");
      in.skip_tokens(n * tokens, std::string("a value of ") + std::string(word));
    }
  }
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (const uint32_t v : mesh.hexes[h])
      if (v >= mesh.points.size())
        throw FormatError("hexahedron " + std::to_string(h + 1) + " refers to vertex " + std::to_string(v + 1ull) +
                          " but the file has " + std::to_string(mesh.points.size()) + " vertices");
  return mesh;
}

}  // namespace mchex::io_detail
