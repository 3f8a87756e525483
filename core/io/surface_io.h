// Reading triangle surfaces from files: our own precheck per format (stl.cpp, obj.cpp, off.cpp,
// ply.cpp), the import through Assimp (assimp_scene.cpp), then the weld (surface_io.cpp).
#pragma once

#include <cstddef>
#include <filesystem>

#include "core/mesh/surface.h"

namespace mchex {

// Reads STL (ascii and binary), OBJ, OFF or PLY, chosen by the extension (any case), welds and
// checks indices and coordinates. Polygons are triangulated; points and lines are ignored;
// vertices no triangle uses are dropped; the rest keep the order of their first use.
// Coordinates pass through single precision (the readers' type). *welded receives how many of
// the file's vertices were duplicates merged by the weld (for STL every facet corner counts).
// Throws InputError("PATH: reason", one line) on anything unreadable, empty, non-finite, out of
// range or without triangles.
TriangleSurface read_surface(const std::filesystem::path& path, std::size_t* welded = nullptr);

}  // namespace mchex
