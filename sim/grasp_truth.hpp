// Grasp ground truth of the depth scenes (docs/grasp.md "Ground truth"): top-down
// parallel-jaw grasps across the narrow sections of the three parts of sim/depth_parts.hpp,
// derived from their geometry, for training and scoring the grasp detectors of
// vision/grasp/ (paper 003 Sec. 4.2: a grasp is G = (p, theta, w, q), eq. (12)).
//
// Each part has a few canonical grasps in its model frame (canonicalGrasps()): a segment of
// grasp centres (the jaws may close anywhere along it), the closing axis (perpendicular to
// the segment) and the section: the distance between the two antipodal faces the jaws close
// on. In a scene, the centres sampled every kGraspStepMm along each segment become ground-
// truth grasp rectangles where all of these hold:
//   (1) the closing axis is within kGraspMaxTiltDeg of the image plane (the gripper
//       approaches along the optical axis, as in GG-CNN);
//   (2) the part is the nearest surface at the centre pixel, and the centre lies at most
//       kGraspMaxReachMm below that surface;
//   (3) both jaws (kJawThickMm across, kJawLengthMm along, kJawClearanceMm from the faces)
//       reach down to the centre's depth without touching anything: every exact surface in
//       their footprints (DepthScene::exactZ) is farther from the camera than the centre;
//   (4) the rectangle lies inside the image.
// The rectangle: centre = the projected grasp centre; across (the closing axis) the opening
// = section + 2 clearances; along, the jaw length; both in px as projected at the centre's
// depth. Angles: the closing axis in the image, degrees counter-clockwise as displayed
// (image y down), in (-90, 90] (a parallel gripper is symmetric under 180 deg).
// Pure code, no I/O, no shared state: any thread.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "sim/depth_scene.hpp"

namespace vgr::sim {

constexpr double kGraspStepMm = 2;        // spacing of the sampled centres along a segment
constexpr double kGraspMaxTiltDeg = 20;   // (1)
constexpr double kGraspMaxReachMm = 25;   // (2)
constexpr double kJawThickMm = 5;         // (3) a jaw's size across (along the closing axis)
constexpr double kJawLengthMm = 10;       // (3) a jaw's size along (the rectangle's height)
constexpr double kJawClearanceMm = 2;     // (3) open jaw to the face it closes on

// A grasp in the part's model frame (mm).
struct CanonicalGrasp {
  std::string name;                // "flange", "base-width", ...
  std::array<double, 3> a{}, b{};  // the segment of grasp centres
  std::array<double, 3> closing{}; // unit closing axis, perpendicular to b - a
  double sectionMm = 0;            // distance between the antipodal faces
};

// Errors: Status::BadArgument for a part that is not a depthPartNames() name.
Result<std::vector<CanonicalGrasp>> canonicalGrasps(const std::string& part);

// One ground-truth grasp rectangle (one sampled centre of one canonical grasp of one part).
struct GraspTruth {
  int part = 0;            // index into DepthScene::parts
  std::string grasp;       // the canonical grasp's name
  int sample = 0;          // index along its segment: samples k and k+1 of one grasp are 2 mm apart
  double u = 0, v = 0;     // px, the centre
  double angleDeg = 0;     // (-90, 90], counter-clockwise as displayed
  double widthPx = 0;      // opening, px
  double jawPx = 0;        // jaw length, px
  Vec3 centreCam;          // the grasp centre, camera frame, mm
  double widthMm = 0;      // opening, mm
};

// The ground truth of a scene rendered with `part` (renderDepthScene's options.part):
// every valid sampled centre of every part, in part then grasp then sample order. Empty
// when no part can be grasped (or the scene has none). Errors: Status::BadArgument for an
// unknown part or a scene without its exact z.
Result<std::vector<GraspTruth>> sceneGraspTruth(const DepthScene& scene, const std::string& part);

}  // namespace vgr::sim
