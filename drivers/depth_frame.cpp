#include "drivers/depth_frame.hpp"

#include <cmath>
#include <cstring>

#include <fmt/format.h>

namespace vgr::drivers {

Result<DepthEncoding> depthEncoding(const Scan3dFeatures& f) {
  auto refuse = [](const std::string& what) { return fail(Status::CameraError, what); };
  double unitMm = 0;
  if (f.distanceUnit.empty()) return refuse("the camera has no Scan3dDistanceUnit: the depth unit is unknown");
  if (f.distanceUnit == "Millimeter") unitMm = 1.0;
  else if (f.distanceUnit == "Meter") unitMm = 1000.0;
  else if (f.distanceUnit == "Inch") unitMm = 25.4;
  else
    return refuse("Scan3dDistanceUnit is '" + f.distanceUnit + "': not a length the driver converts to mm (Millimeter, Meter, Inch)");
  if (!f.coordinateSystem.empty() && f.coordinateSystem != "Cartesian")
    return refuse("Scan3dCoordinateSystem is '" + f.coordinateSystem + "': a z-depth map needs Cartesian");
  if (!f.outputMode.empty() && f.outputMode != "RectifiedC" && f.outputMode != "CalibratedC" && f.outputMode != "ProjectedC")
    return refuse("Scan3dOutputMode is '" + f.outputMode + "': not a calibrated z map (RectifiedC, CalibratedC or ProjectedC)");
  if (!f.scale) return refuse("the camera has no Scan3dCoordinateScale: raw values cannot be turned into mm");
  if (!(*f.scale > 0) || !std::isfinite(*f.scale))
    return refuse(fmt::format("Scan3dCoordinateScale is {}: expected a positive number", *f.scale));
  const double offset = f.offset.value_or(0.0);
  if (!std::isfinite(offset)) return refuse("Scan3dCoordinateOffset is not finite");
  if (!f.focalLength || !(*f.focalLength > 0))
    return refuse("the camera has no positive Scan3dFocalLength: the depth image has no intrinsics");
  if (!f.principalPointU || !f.principalPointV || !std::isfinite(*f.principalPointU) || !std::isfinite(*f.principalPointV))
    return refuse("the camera has no Scan3dPrincipalPointU/V: the depth image has no intrinsics");
  DepthEncoding e;
  e.scaleMm = *f.scale * unitMm;
  e.offsetMm = offset * unitMm;
  if (f.invalidFlag.value_or(false) && f.invalidValue) {
    const double v = *f.invalidValue;
    if (!(v >= 0 && v <= 65535 && v == std::floor(v)))
      return refuse(fmt::format("Scan3dInvalidDataValue is {}: not a 16-bit raw value", v));
    e.invalidRaw = static_cast<std::uint16_t>(v);
  }
  e.intrinsics = {*f.focalLength, *f.focalLength, *f.principalPointU, *f.principalPointV};
  return e;
}

std::string describe(const Scan3dFeatures& f, const DepthEncoding& e) {
  return fmt::format("Coord3D_C16: {:g} mm/unit + {:g} mm, invalid raw {}, f {:g} px, c ({:g}, {:g}) px, {}{}{}", e.scaleMm,
                     e.offsetMm, e.invalidRaw ? std::to_string(*e.invalidRaw) : std::string("none"), e.intrinsics.fx,
                     e.intrinsics.cx, e.intrinsics.cy, f.distanceUnit, f.outputMode.empty() ? "" : ", ", f.outputMode);
}

Result<DepthParts> selectDepthParts(const std::vector<BufferPart>& parts) {
  DepthParts d;
  bool range = false;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (!range && parts[i].pixelFormat == kPixelCoord3dC16) {
      d.range = i;
      range = true;
    }
  }
  if (!range) {
    std::string seen;
    for (const auto& p : parts) seen += fmt::format("{}0x{:08x}", seen.empty() ? "" : ", ", p.pixelFormat);
    return fail(Status::CameraError, "no Coord3D_C16 range part in the buffer (parts: " + (seen.empty() ? "none" : seen) + ")");
  }
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const auto& p = parts[i];
    const bool confidence = p.dataType == kPartDataTypeConfidenceMap || p.pixelFormat == kPixelConfidence8 ||
                            p.pixelFormat == kPixelConfidence16;
    if (confidence && (p.pixelFormat == kPixelConfidence8 || p.pixelFormat == kPixelConfidence16) &&
        p.width == parts[d.range].width && p.height == parts[d.range].height) {
      d.confidence = i;
      break;
    }
  }
  return d;
}

Result<void> convertDepth(const BufferPart& range, const BufferPart* confidence, const DepthEncoding& e,
                          std::vector<std::uint8_t>& out) {
  const std::size_t n = static_cast<std::size_t>(range.width) * static_cast<std::size_t>(range.height);
  if (range.width <= 0 || range.height <= 0 || range.data == nullptr || range.size < n * 2)
    return fail(Status::CameraError, fmt::format("range part: {} bytes for {}x{} Coord3D_C16 samples", range.size,
                                                 range.width, range.height));
  const int confBytes = confidence ? (confidence->pixelFormat == kPixelConfidence16 ? 2 : 1) : 0;
  if (confidence && (confidence->data == nullptr || confidence->size < n * static_cast<std::size_t>(confBytes)))
    return fail(Status::CameraError, fmt::format("confidence part: {} bytes for {}x{} samples", confidence->size,
                                                 range.width, range.height));
  out.resize(n * sizeof(float));
  auto* z = reinterpret_cast<float*>(out.data());
  for (std::size_t i = 0; i < n; ++i) {
    std::uint16_t raw;
    std::memcpy(&raw, range.data + 2 * i, 2);  // GVSP Coord3D_C16 is little-endian, as our hosts
    double mm = raw * e.scaleMm + e.offsetMm;
    if ((e.invalidRaw && raw == *e.invalidRaw) || !(mm > 0)) mm = 0;
    if (confidence) {
      std::uint16_t c = 0;
      if (confBytes == 2)
        std::memcpy(&c, confidence->data + 2 * i, 2);
      else
        c = confidence->data[i];
      if (c == 0) mm = 0;
    }
    z[i] = static_cast<float>(mm);
  }
  return {};
}

}  // namespace vgr::drivers
