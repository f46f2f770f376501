// Small geometry helpers of vision/cloud/ (no Open3D): poses <-> 4x4 matrices, back-
// projection of a depth image, the visibility check behind our fitness (paper 004 Sec. 3.2,
// "fitness ... measured the overlapping area"; docs/3d.md "Fitness"), rotation and
// translation errors. Units mm; camera frame x right, y down, z forward. Any thread.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/search3d.hpp"

namespace vgr::vision::cloud {

using DepthIntrinsics = vgr::DepthIntrinsics;

Eigen::Matrix4d toMatrix(const Pose& p);
Pose toPose(const Eigen::Matrix4d& t);  // unit quaternion with qw >= 0

// Every valid pixel (z > 0) inside the ROI box as a camera-frame point (mm): x = (u - cx) z / fx,
// y = (v - cy) z / fy. `step` > 1 takes every step-th pixel in both directions.
std::vector<Eigen::Vector3d> backProject(const cv::Mat& depthMm, const DepthIntrinsics& k, const RoiBox& roi, int step = 1);

// How well the view supports a model pose. For every model point that faces the camera
// (within visibleMaxAngleDeg of the ray), lies in the image and is not hidden by the model
// itself, the measured z at its pixel (3 x 3 neighbourhood) says:
//   matched       |z_measured - z| <= tolerance            the sensor sees the model's surface
//   occluded      z_measured < z - tolerance                something in front hides it
//   contradicted  every measured z > z + tolerance         the sensor sees through the model
//   unknown       no valid pixel                            (dropout, shadows): not counted
// fitness = matched / (matched + occluded + contradicted): the share of what this viewpoint
// should show of the part that it does show (paper 004's overlap, made independent of how
// much of a part one view can see); contradiction = contradicted / the same.
// continuation: of the valid pixels in a ring kRingMm wide just outside the model's
// silhouette, the share whose measured z is within tolerance of the nearest model z: the
// measured surface runs on past the part's edge. A real part's silhouette is a depth edge
// (the background lies behind it, or an occluder in front); a model face laid into a larger
// surface of the same depth (a bin's rim, a table outside the bin, a big clutter face, the
// rest of the model hidden behind it) fits that surface 100 % but its edge is not there.
inline constexpr double kRingMm = 4;
struct Visibility {
  double fitness = 0, contradiction = 0, continuation = 0;
  int matched = 0, occluded = 0, contradicted = 0, unknown = 0;
  int outside = 0;  // front-facing model points projected outside the image (before the self-hiding test)
};
// The `claimed` image of VisibilityCheck (CV_8UC1, image size): what a pixel already is.
//   kPixelClaimed  a part found before explains it: unknown for every later check
//   kPixelPlane    on the removed dominant plane (table, bin floor) or beyond it: a model
//                  point matched there is unknown (a part's face lying in the table plane
//                  with the rest of the part hidden "below" it would otherwise fit 100 %);
//                  the sensor seeing the table through a model point still contradicts it
inline constexpr std::uint8_t kPixelFree = 0, kPixelClaimed = 1, kPixelPlane = 2;

class VisibilityCheck {
 public:
  // points / normals: the model (model frame, mm), spaced about spacingMm.
  VisibilityCheck(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals, double spacingMm);
  // claimed (CV_8UC1, optional): pixels of parts found before; they count as unknown.
  Visibility check(const Eigen::Matrix4d& camFromModel, const cv::Mat& depthMm, const DepthIntrinsics& k, double toleranceMm,
                   double visibleMaxAngleDeg, const cv::Mat& claimed = cv::Mat());
  // Pose refinement against the depth image's boundaries (docs/3d.md "Refinement"): seen
  // from above, a part's walls are too steep for the sensor, so point-to-plane ICP on its
  // top faces cannot fix where it lies sideways (measured: up to 3.6 mm off after ICP from
  // a 4 mm / 5 deg start). This moves the pose (coordinate descent over the 3 translations
  // and 3 rotations about the part's centroid, steps 0.8 down to 0.05 mm / deg) to minimise
  // the cost of the model points visible at the start pose: 0.25 (r / tol)^2 where the
  // measured z is within tol of the point's (r the difference), 0.25 where something in
  // front hides it or nothing is known, 1 where the sensor sees through it. An invalid pixel
  // takes the nearest-z valid 4-neighbour, so the invalid band at a depth edge splits at the
  // true edge instead of leaving a 1-pixel plateau. Returns the refined camFromModel.
  // `directions`: the motions to search along (6-vectors: rotation about the centroid scaled
  // to mm at radiusMm, translation in mm; camera frame); empty = the 6 axes. `stiffness`
  // (one per direction, cost per mm^2, may be empty): a quadratic cost of moving along it
  // (ICP's J^T J / sigma^2: what the measured surfaces say against the move).
  Eigen::Matrix4d alignToBoundaries(const Eigen::Matrix4d& camFromModel, const Eigen::Vector3d& modelCentroid, double radiusMm,
                                    const std::vector<Eigen::Matrix<double, 6, 1>>& directions, const std::vector<double>& stiffness,
                                    const cv::Mat& depthMm,
                                    const DepthIntrinsics& k, double toleranceMm, double visibleMaxAngleDeg,
                                    const cv::Mat& claimed = cv::Mat());
  // Sub-pixel silhouette alignment (docs/3d.md "Orientation"): the model's occluding contour
  // at camFromModel (visible model points next to an empty or >= 3 mm deeper pixel of the
  // model's own z-buffer) is pulled onto the measured depth edges (valid pixels next to a
  // depth jump of >= 3 mm or to a jump's invalid band, isolated dropout pixels ignored) by
  // Gauss-Newton on the squared, bilinearly interpolated distance transform of those edges
  // (truncated at 3 px), along `directions` with ICP's `stiffness` as a prior (as in
  // alignToBoundaries). The boundary cost above works on whole pixels: on flat parts seen
  // from above its turn about the view axis was 1-2 deg off (bracket scenes 105 / 134).
  Eigen::Matrix4d alignToEdges(const Eigen::Matrix4d& camFromModel, const Eigen::Vector3d& modelCentroid, double radiusMm,
                               const std::vector<Eigen::Matrix<double, 6, 1>>& directions, const std::vector<double>& stiffness,
                               const cv::Mat& depthMm, const DepthIntrinsics& k, double visibleMaxAngleDeg, double edgeSigmaPx,
                               const cv::Mat& claimed = cv::Mat());
  // Marks in `claimed` (CV_8UC1, image size) the pixels where the model under camFromModel is
  // what the sensor sees (matched points, splatted to their spacing).
  void claim(const Eigen::Matrix4d& camFromModel, const cv::Mat& depthMm, const DepthIntrinsics& k, double toleranceMm,
             double visibleMaxAngleDeg, cv::Mat& claimed);

 private:
  std::vector<Eigen::Vector3d> points_, normals_;
  double spacingMm_;
  cv::Mat zbuf_;  // scratch: the model's own z-buffer
  cv::Mat edges_, edgeDist_;  // scratch: alignToEdges' measured edges and their distance transform
  cv::Mat ringIn_, ringNear_;  // scratch: the silhouette ring (check())
  std::vector<Eigen::Vector4d> front_;  // scratch: u, v, z, index of the front-facing points
  // Front-facing points in the image not hidden by the model itself (indices); fills front_, zbuf_.
  std::vector<std::size_t> visibleSet(const Eigen::Matrix4d& t, const cv::Mat& depthMm, const DepthIntrinsics& k, double maxAngleDeg);
};

// The points a viewer looking along `direction` (unit, model frame) sees: facing it within
// maxAngleDeg and not hidden behind other points (an orthographic z-buffer of cellMm cells,
// a point is hidden when a point of its 3 x 3 cells is nearer by more than 2 cells).
std::vector<std::size_t> visibleFrom(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                                     const Eigen::Vector3d& direction, double cellMm, double maxAngleDeg);

// Angle of the rotation between two poses (deg) and the distance between their origins (mm).
double rotationErrorDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b);
double translationErrorMm(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b);

}  // namespace vgr::vision::cloud
