// The GenICam description of the emulator as a depth camera: Aravis' stock fake-camera XML
// (arv_fake_camera_get_genicam_xml) with a Coord3D_C16 entry in PixelFormat and a
// Scan3dControl category (SFNC names) whose features live in the fake camera's register
// memory at kScan3dBase (PITFALLS.md "3D": loaded with arv_gv_fake_camera_new_full).
// Pure string work; the emulator writes the registers.
#pragma once

#include <cstdint>
#include <string>

#include "core/result.hpp"

namespace vgr::sim {

inline constexpr std::uint32_t kPixelFormatCoord3dC16 = 0x011000B8u;

// Register addresses (fake camera memory, big-endian): enumerations and the flag are 32-bit
// integers, the Float features 64-bit IEEE doubles.
inline constexpr std::uint32_t kScan3dBase = 0x8000;
inline constexpr std::uint32_t kScan3dDistanceUnit = kScan3dBase + 0x00;      // 0 Millimeter, 1 Inch, 2 Pixel
inline constexpr std::uint32_t kScan3dCoordinateSelector = kScan3dBase + 0x04;  // 0 A, 1 B, 2 C (RW)
inline constexpr std::uint32_t kScan3dCoordinateSystem = kScan3dBase + 0x08;  // 0 Cartesian
inline constexpr std::uint32_t kScan3dOutputMode = kScan3dBase + 0x0c;        // 0 RectifiedC, 1 UncalibratedC
inline constexpr std::uint32_t kScan3dInvalidDataFlag = kScan3dBase + 0x10;   // 0 / 1
inline constexpr std::uint32_t kScan3dCoordinateScale = kScan3dBase + 0x20;
inline constexpr std::uint32_t kScan3dCoordinateOffset = kScan3dBase + 0x28;
inline constexpr std::uint32_t kScan3dInvalidDataValue = kScan3dBase + 0x30;
inline constexpr std::uint32_t kScan3dFocalLength = kScan3dBase + 0x38;
inline constexpr std::uint32_t kScan3dPrincipalPointU = kScan3dBase + 0x40;
inline constexpr std::uint32_t kScan3dPrincipalPointV = kScan3dBase + 0x48;

// `stockXml` extended; an error when the stock XML lacks the anchors it is patched at (a
// changed Aravis), naming which.
Result<std::string> depthCameraXml(const std::string& stockXml);

}  // namespace vgr::sim
