// Poses in millimetres with a unit quaternion; conversions to each wire convention.
// Frames: T_a_b maps points from frame b to frame a (ARCHITECTURE.md, "Units").
// Eigen stays out of this header on purpose: it is included by protocol and daemon code.
#pragma once

namespace vgr {

struct Pose {
  double x = 0, y = 0, z = 0;              // mm
  double qw = 1, qx = 0, qy = 0, qz = 0;   // unit quaternion (w, x, y, z)
};

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

// Rotation about the base Z axis by rz radians, at (x, y, z) mm.
Pose poseFromXyzRz(double x, double y, double z, double rzRad);

// Z-Y-X Euler angles in degrees: R = Rz(rz) * Ry(ry) * Rx(rx). This is ABB's
// OrientZYX(rz, ry, rx) and FANUC's W,P,R (W = rx, P = ry, R = rz).
struct EulerZyxDeg {
  double rz = 0, ry = 0, rx = 0;
};
EulerZyxDeg toEulerZyxDeg(const Pose& p);

// Rotation vector (axis * angle) in radians, as URScript's p[x, y, z, rx, ry, rz].
Vec3 toRotationVector(const Pose& p);

// The inverse conversions, for poses a robot sends (eye-in-hand snapshots, pose files) and
// poses written in cell.yaml (user frames: poseFromEulerZyxDeg(x, y, z, {rz, ry, rx})):
// (x, y, z) mm with a rotation given as Z-Y-X Euler degrees, a rotation vector (rad) or a
// quaternion (w, x, y, z; normalised here, returned with qw >= 0). Callers check that the
// inputs are finite and, for a quaternion, that its norm is near 1 (protocol/robot_codec).
Pose poseFromEulerZyxDeg(double x, double y, double z, const EulerZyxDeg& e);
Pose poseFromRotationVector(double x, double y, double z, const Vec3& rotationVectorRad);
Pose poseFromQuaternion(double x, double y, double z, double qw, double qx, double qy, double qz);

// Composition a * b and inverse, for T_base_ref^-1 * T_base_part style offsets.
Pose compose(const Pose& a, const Pose& b);
Pose inverse(const Pose& p);

}  // namespace vgr
