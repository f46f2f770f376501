// Angle helpers shared by the renderer, the locators, the daemon and the tools (degrees).
#pragma once

#include <cmath>

namespace vgr {

// `a` mapped into (-180, 180].
inline double normaliseDeg(double a) {
  a = std::fmod(a, 360.0);
  if (a <= -180.0) a += 360.0;
  if (a > 180.0) a -= 360.0;
  return a;
}

// Distance of two angles on the circle, [0, 180].
inline double angleDiffDeg(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

}  // namespace vgr
