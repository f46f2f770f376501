// Depth cameras (GenICam SFNC "3D"): what the driver reads from the camera's Scan3d features
// and how it turns a Coord3D_C16 range image (and, for a multipart camera, its confidence
// map) into a depth frame: float32 z in mm, 0 = no data, plus the pinhole intrinsics
// (core/depth.hpp). Pure functions, no Aravis: the Aravis driver fills these structs and the
// tests check the arithmetic without a camera.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/depth.hpp"
#include "core/result.hpp"

namespace vgr::drivers {

// The Scan3d features as the camera reports them (SFNC 2.x, Scan3dControl), after
// Scan3dCoordinateSelector = CoordinateC. Strings are the enumeration entries; a feature the
// camera lacks is empty / nullopt.
struct Scan3dFeatures {
  std::string distanceUnit;       // Scan3dDistanceUnit: "Millimeter", "Inch", ...
  std::string coordinateSystem;   // Scan3dCoordinateSystem: "Cartesian", ...
  std::string outputMode;         // Scan3dOutputMode: "RectifiedC", "CalibratedC", ...
  std::optional<double> scale;    // Scan3dCoordinateScale: unit per raw value
  std::optional<double> offset;   // Scan3dCoordinateOffset: unit
  std::optional<bool> invalidFlag;        // Scan3dInvalidDataFlag
  std::optional<double> invalidValue;     // Scan3dInvalidDataValue: the raw value marking "no data"
  std::optional<double> focalLength;      // Scan3dFocalLength, px
  std::optional<double> principalPointU;  // Scan3dPrincipalPointU, px
  std::optional<double> principalPointV;  // Scan3dPrincipalPointV, px
};

// How raw Coord3D_C16 values become z: z_mm = raw * scaleMm + offsetMm; `invalidRaw` (when
// set) marks a pixel without data, as does z <= 0.
struct DepthEncoding {
  double scaleMm = 0;
  double offsetMm = 0;
  std::optional<std::uint16_t> invalidRaw;
  DepthIntrinsics intrinsics;
};

// The encoding the features describe, or the reason the driver cannot use the camera, naming
// the feature ("Scan3dDistanceUnit is 'Pixel': ..."): an unknown unit, a non-Cartesian
// coordinate system, an output mode that is not a calibrated z map (UncalibratedC,
// DisparityC, ...), a missing or non-positive scale, focal length or principal point.
// Scan3dCoordinateOffset absent = 0; no Scan3dInvalidDataFlag, or it off = no invalid value.
// Units: Millimeter (x 1), Meter (x 1000), Inch (x 25.4).
Result<DepthEncoding> depthEncoding(const Scan3dFeatures& features);
// One line for the log: "Coord3D_C16: 0.25 mm/unit + 0 mm, invalid raw 0, f 570 px, c (319.5, 239.5) px, Millimeter, RectifiedC".
std::string describe(const Scan3dFeatures& features, const DepthEncoding& encoding);

// One part of a (multipart) buffer, as the driver sees it.
struct BufferPart {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;         // bytes
  int width = 0, height = 0;    // px
  std::uint32_t pixelFormat = 0;  // PFNC code
  int dataType = 0;             // GigE Vision part data type (1 2D image, 5 3D image, 9 confidence map, ...)
};
inline constexpr std::uint32_t kPixelCoord3dC16 = 0x011000B8u;
inline constexpr std::uint32_t kPixelConfidence8 = 0x010800C6u;
inline constexpr std::uint32_t kPixelConfidence16 = 0x011000C7u;
inline constexpr int kPartDataTypeConfidenceMap = 0x0009;

// Which parts are the range image (Coord3D_C16) and its confidence map (Confidence8/16,
// same size): the range part is required; the rest (intensity, ...) is ignored.
struct DepthParts {
  std::size_t range = 0;
  std::optional<std::size_t> confidence;
};
Result<DepthParts> selectDepthParts(const std::vector<BufferPart>& parts);

// Converts one range image into `out` (width * height floats, resized; no allocation once
// warm). A pixel is 0 (no data) when its raw value is the invalid one, its z <= 0, or its
// confidence (when given) is 0. Errors: a part smaller than width x height samples.
Result<void> convertDepth(const BufferPart& range, const BufferPart* confidence, const DepthEncoding& encoding,
                          std::vector<std::uint8_t>& out);

}  // namespace vgr::drivers
