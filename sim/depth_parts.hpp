// The three asymmetric parts of the 3D data sets (docs/3d.md "Parts"): unions of boxes and
// z-axis cylinders in the part's model frame (mm). No part has a rotational symmetry, and
// every face it can rest on shows an asymmetric relief, so a pose is unique (paper 004
// Sec. 5 lost its air pipe to symmetry).
//
//   bracket  an L-bracket: 60 x 40 x 8 base plate, 32 mm flange along one long edge, an
//            off-centre rib and a round boss
//   housing  a 50 x 36 x 22 block with a side tab at its foot, a boss and a pin on top
//   lever    two hubs of different size joined by an arm, flush at the bottom, with a lug
//
// Meshes are exact for the renderer (each primitive closed; overlaps are resolved by the
// z-buffer). The exterior surface (what a sensor can see) is what sampleSurface() and
// exteriorMesh() give: points / triangles of a primitive that lie inside or on another
// primitive are left out. Immutable data, no I/O; any thread.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::sim {

// A triangle mesh in mm; triangles index `vertices`, counter-clockwise seen from outside.
struct TriMesh {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<int, 3>> triangles;
};

// A point of the exterior surface with its outward unit normal, model frame, mm.
struct SurfacePoint {
  double x = 0, y = 0, z = 0;
  double nx = 0, ny = 0, nz = 1;
};

// A box [min, max] or a cylinder about a z-parallel axis at (cx, cy), z in [z0, z1].
struct Primitive {
  enum class Kind { Box, Cylinder } kind = Kind::Box;
  std::array<double, 3> min{}, max{};  // box, mm
  double cx = 0, cy = 0, radius = 0, z0 = 0, z1 = 0;  // cylinder, mm
};

// A rotation (row-major 3x3) that puts a part on one of its stable faces: applied to model
// coordinates it gives coordinates in a frame whose -z points to the floor, with the part's
// lowest point at z = min over vertices (callers lift it onto the floor).
struct StableFace {
  std::array<double, 9> rotation{};
  std::string name;  // "-z", "+x", ...: the model axis pointing down
};

struct DepthPart {
  std::string name;
  std::vector<Primitive> primitives;
  TriMesh mesh;                       // every primitive's closed mesh (for rendering)
  std::vector<StableFace> stableFaces;  // at least one; [0] is the natural one (-z down)
  double radiusMm = 0;                // bounding radius about the model origin
  std::array<double, 3> centroid{};   // volume centroid (mm, model frame)
};

// The closed mesh of the axis-aligned box [lo, hi] (mm), counter-clockwise seen from outside:
// the bins, tables and clutter of the scenes, and test scenes, are built of these.
TriMesh boxMesh(const std::array<double, 3>& lo, const std::array<double, 3>& hi);

const std::vector<std::string>& depthPartNames();  // {"bracket", "housing", "lever"}
// Errors: Status::BadArgument "unknown part 'x' (expected bracket, housing or lever)".
Result<DepthPart> depthPart(const std::string& name);

// Points of the exterior surface on a grid of `spacingMm` over every primitive face.
std::vector<SurfacePoint> sampleSurface(const DepthPart& part, double spacingMm);
// The exterior surface as triangles no longer than `edgeMm`: each primitive face subdivided,
// triangles whose centre is not on the exterior left out (so the boundary of touching or
// overlapping primitives is right to within edgeMm).
TriMesh exteriorMesh(const DepthPart& part, double edgeMm);

}  // namespace vgr::sim
