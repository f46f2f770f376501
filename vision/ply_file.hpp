// ASCII PLY point clouds and triangle meshes (docs/3d.md "Data-set format"): model.ply
// (x y z nx ny nz, mm, model frame) and mesh.ply (vertices + triangles). Our own reader and
// writer rather than Open3D's, because the reader must name file and line for a bad input
// (Open3D's answers "Read PLY failed") and must not pull Open3D into every target that reads
// a data set. Binary PLY is refused with a clear message. Start-up style I/O, any thread.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::vision {

struct PlyCloud {
  std::vector<std::array<double, 3>> points;   // mm
  std::vector<std::array<double, 3>> normals;  // unit vectors, one per point, or empty
  bool hasNormals() const { return !normals.empty(); }
};

struct PlyMesh {
  std::vector<std::array<double, 3>> vertices;  // mm
  std::vector<std::array<int, 3>> triangles;    // indices into vertices
};

// Errors (Status::BadArgument): "FILE: cannot open", "FILE:LINE: what" for a header or a
// number that does not parse, a missing x/y/z property, a count that does not match, a
// non-finite value, a zero normal, a face that is not a triangle or indexes past the vertices.
// readPlyCloud reads the vertices of any PLY (faces ignored); normals are kept when the
// file has nx, ny and nz (normalised to unit length).
Result<PlyCloud> readPlyCloud(const std::string& path);
Result<PlyMesh> readPlyMesh(const std::string& path);

// Writes ASCII PLY (replacing the file); numbers to 1 µm and normals to 6 decimals.
// Errors: Status::Internal "FILE: cannot write".
Result<void> writePlyCloud(const std::string& path, const PlyCloud& cloud, const std::string& comment = "");
Result<void> writePlyMesh(const std::string& path, const PlyMesh& mesh, const std::string& comment = "");

}  // namespace vgr::vision
