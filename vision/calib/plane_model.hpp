// Pixel <-> conveyor-plane mapping with a pinhole camera of known pose: the ray/plane
// back-projection of paper 002 (eqs. 9-11, the "virtual plane" with the part height added).
// Pure geometry: no I/O, no threads; cheap to copy.
#pragma once

#include <optional>

#include "core/pose.hpp"
#include "core/taught_template.hpp"  // PixelPoint

namespace vgr::vision {

using vgr::PixelPoint;  // core/taught_template.hpp: px, x right, y down, pixel centres at integers

class PinholePlaneModel {
 public:
  // fx, fy, cx, cy in px (no distortion in this model); T_base_cam: the camera frame
  // (x right, y down, z along the optical axis) in the robot base frame, mm;
  // planeZ: conveyor plane height in the base frame, mm.
  PinholePlaneModel(double fx, double fy, double cx, double cy, const Pose& baseFromCamera, double planeZ);

  // A camera looking straight down from (x, y, z) with its image x axis turned rzDeg
  // about base z (the simulated cell's mount).
  static Pose downLookingCamera(double x, double y, double z, double rzDeg);

  // Intersection of the pixel's viewing ray with the plane z = planeZ + heightMm (base
  // frame). Empty when the ray is parallel to or points away from the plane.
  std::optional<Vec3> pixelToPlane(PixelPoint p, double heightMm = 0) const;

  // Projection of a base-frame point; empty when it lies behind the camera.
  std::optional<PixelPoint> project(const Vec3& pointBase) const;

  double planeZ() const { return planeZ_; }

 private:
  double fx_, fy_, cx_, cy_;
  Pose baseFromCamera_;
  double planeZ_;
};

}  // namespace vgr::vision
