// Scoring a detected grasp against ground-truth grasp rectangles (docs/grasp.md "Evaluation"):
//   rectangle metric  the usual one of the Cornell and Jacquard benchmarks: a grasp is right
//                     when its rectangle overlaps a true one with IoU >= 0.25 and their angles
//                     differ by at most 30 deg (modulo 180: a parallel gripper is symmetric)
//   position          paper 003's bound (Sec. 5, Table 1: "grasping accuracy within 2 mm"):
//                     the distance in mm, across the optical axis at the true centre's depth,
//                     from the grasp centre to the nearest true centre of a matching grasp;
//                     the true centres of one canonical grasp sampled 2 mm apart form a
//                     polyline (any point on it is a true centre), so the distance is to it.
// Image px, angles in degrees counter-clockwise as displayed. Pure code, any thread.
#pragma once

#include <vector>

namespace vgr::vision::grasp {

struct GraspRect {
  double u = 0, v = 0;      // centre, px
  double angleDeg = 0;      // closing axis
  double widthPx = 0;       // across (opening)
  double jawPx = 0;         // along
};

// |a - b| modulo 180, in [0, 90].
double angleDiffDeg(double a, double b);

// Intersection over union of two rotated rectangles (0 when either is empty).
double rectIou(const GraspRect& a, const GraspRect& b);

struct RectMetric {
  double minIou = 0.25;
  double maxAngleDeg = 30;
};

// A true rectangle with what the position bound needs: the true centre's depth (for px ->
// mm), and which polyline it belongs to (consecutive samples of one canonical grasp).
struct TruthRect {
  GraspRect rect;
  double depthMm = 0;
  double fx = 0;        // px, for px -> mm at depthMm
  int polyline = 0;     // samples of one canonical grasp of one part share it
  int sample = 0;       // its index along the polyline (k and k + 1 are neighbours)
};

struct GraspScore {
  bool rectSuccess = false;  // matches some true rectangle by the rectangle metric
  double bestIou = 0;        // the highest IoU among true rectangles within the angle bound
  double angleErrDeg = 0;    // to the matched (or, when none matches, the nearest) true rectangle
  double posErrMm = -1;      // to the polyline of the matched grasp; -1 when none matched
};

// Scores one detected grasp against an image's true rectangles (empty truth: no success).
GraspScore scoreGrasp(const GraspRect& detected, const std::vector<TruthRect>& truth, const RectMetric& metric = {});

}  // namespace vgr::vision::grasp
