// The Assimp import behind read_surface: bytes that a precheck accepted, parsed from memory, the
// scene checked, triangulated, and its triangles collected in the node tree's transforms.
//
// Assimp sees only the buffer (NoFileAccess), prints nothing (no logger is created), and is not
// asked to triangulate until the scene has been checked (indices in range, finite coordinates,
// polygon size), since aiProcess_Triangulate assumes a well-formed mesh. Its messages are cut to
// one line and its in-memory file name is replaced by "the file".
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"

namespace mchex::io_detail {
namespace {

namespace fs = std::filesystem;

// Assimp may only see the buffer we hand it: an OBJ's "mtllib" must not make it open (or block
// on) another file.
class NoFileAccess : public Assimp::IOSystem {
 public:
  bool Exists(const char*) const override { return false; }
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char*, const char*) override { return nullptr; }
  void Close(Assimp::IOStream*) override {}
};

std::string assimp_reason(const Assimp::Importer& importer) {
  std::string reason = importer.GetErrorString();
  // Reading from memory, Assimp names the file "$$$___magic___$$$.<ext>".
  for (std::size_t at; (at = reason.find("$$$___magic___$$$")) != std::string::npos;) {
    std::size_t end = at + 17;
    while (end < reason.size() && reason[end] != ' ' && reason[end] != ',') ++end;
    if (end > at + 17 && reason[end - 1] == '.') --end;
    reason.replace(at, end - at, "the file");
  }
  // Some messages quote the rest of the file; the first line says what went wrong.
  reason = reason.substr(0, reason.find_first_of("\r\n"));
  if (reason.size() > 160) reason = reason.substr(0, 160) + "...";
  return reason.empty() ? "unknown error" : reason;
}

// Checks what Assimp produced before triangulation runs on it. Returns whether any face is a
// polygon (more than three corners).
bool check_scene(const fs::path& path, const aiScene& scene) {
  bool polygons = false;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh* mesh = scene.mMeshes[m];
    if (mesh == nullptr) fail(path, "the reader returned an empty mesh");
    if (mesh->mNumVertices > 0 && mesh->mVertices == nullptr)
      fail(path, "the reader returned a mesh without positions");
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        char buffer[128];
        std::snprintf(buffer, sizeof buffer, "(%g, %g, %g)", static_cast<double>(p.x), static_cast<double>(p.y),
                      static_cast<double>(p.z));
        fail(path, std::string("has a vertex with a non-finite coordinate ") + buffer +
                       "; NaN and infinity cannot be meshed");
      }
    }
    if (mesh->mNumFaces > 0 && mesh->mFaces == nullptr) fail(path, "the reader returned a mesh without faces");
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr) fail(path, "has a face without vertices");
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          fail(path, "a face refers to vertex " + std::to_string(face.mIndices[k]) + ", but there are only " +
                         std::to_string(mesh->mNumVertices) + " vertices");
        }
      }
      if (face.mNumIndices > kMaxPolygonCorners) {
        fail(path, "has a face with " + std::to_string(face.mNumIndices) + " corners; at most " +
                       std::to_string(kMaxPolygonCorners) + " are supported (triangulate the model first)");
      }
      polygons = polygons || face.mNumIndices > 3;
    }
  }
  return polygons;
}

// Every mesh instance in the node tree, with its node's transform; vertices are kept only if a
// triangle uses them, in order of first use (the weld then keeps that order).
Collected collect_triangles(const fs::path& path, const aiScene& scene) {
  Collected out;
  if (scene.mRootNode == nullptr) return out;
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{{scene.mRootNode, scene.mRootNode->mTransformation}};
  std::vector<uint32_t> remap;
  while (!stack.empty()) {
    const auto [node, transform] = stack.back();
    stack.pop_back();
    for (unsigned c = node->mNumChildren; c-- > 0;) {
      if (node->mChildren[c] != nullptr)
        stack.emplace_back(node->mChildren[c], transform * node->mChildren[c]->mTransformation);
    }
    const bool identity = transform.IsIdentity();
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      if (node->mMeshes[i] >= scene.mNumMeshes) fail(path, "the reader returned a scene that refers to a missing mesh");
      const aiMesh& mesh = *scene.mMeshes[node->mMeshes[i]];
      remap.assign(mesh.mNumVertices, std::numeric_limits<uint32_t>::max());
      for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices < 3) {
          ++out.other_primitives;
          continue;
        }
        if (face.mNumIndices > 3) fail(path, "a polygon could not be split into triangles");
        std::array<uint32_t, 3> triangle{};
        for (unsigned k = 0; k < 3; ++k) {
          const unsigned v = face.mIndices[k];
          if (v >= mesh.mNumVertices) fail(path, "a triangle refers to a missing vertex");
          if (remap[v] == std::numeric_limits<uint32_t>::max()) {
            if (out.surface.vertices.size() >= std::numeric_limits<uint32_t>::max())
              fail(path, "has more than 2^32 vertices");
            remap[v] = static_cast<uint32_t>(out.surface.vertices.size());
            aiVector3D p = mesh.mVertices[v];
            if (!identity) p = transform * p;
            out.surface.vertices.push_back(
                {static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z)});
            if (!is_finite(out.surface.vertices.back()))
              fail(path, "has a vertex that becomes non-finite when placed in the scene");
          }
          triangle[k] = remap[v];
        }
        out.surface.triangles.push_back(triangle);
      }
    }
  }
  return out;
}

}  // namespace

Collected import_scene(const std::filesystem::path& path, std::string_view bytes, const char* hint,
                       const char* format) {
  Assimp::Importer importer;
  importer.SetIOHandler(new NoFileAccess);  // the importer owns it
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(), 0, hint);
    if (scene == nullptr) {
      fail(path, std::string("could not be read as ") + format + ": " + assimp_reason(importer));
    }
    if (check_scene(path, *scene)) {
      scene = importer.ApplyPostProcessing(aiProcess_Triangulate);
      if (scene == nullptr) fail(path, "its polygons could not be split into triangles: " + assimp_reason(importer));
    }
  } catch (const std::bad_alloc&) {
    fail(path, "ran out of memory while reading");
  }

  return collect_triangles(path, *scene);
}

}  // namespace mchex::io_detail
