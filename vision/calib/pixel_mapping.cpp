#include "vision/calib/pixel_mapping.hpp"

#include <fmt/core.h>

#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/multi_height.hpp"

namespace vgr::vision::calib {
namespace {

class PinholeMapping final : public PixelMapping {
 public:
  explicit PinholeMapping(const PinholePlaneModel& m) : model_(m) {}
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const override { return model_.pixelToPlane(p, heightMm); }
  std::optional<ImageSize> imageSize() const override { return std::nullopt; }
  std::string describe() const override { return "pinhole model"; }

 private:
  PinholePlaneModel model_;
};

class CalibratedMapping final : public PixelMapping {
 public:
  explicit CalibratedMapping(const CameraPlaneMapping& m) : mapping_(m) {}
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const override { return mapping_.pixelToRobot(p, heightMm); }
  std::optional<ImageSize> imageSize() const override {
    return ImageSize{mapping_.camera().imageSize.width, mapping_.camera().imageSize.height};
  }
  std::string describe() const override { return "calibration files (intrinsics, hand-eye, plane)"; }

 private:
  CameraPlaneMapping mapping_;
};

class MultiHeightMapping final : public PixelMapping {
 public:
  MultiHeightMapping(const MultiHeightMap& m, ImageSize size) : map_(m), size_(size) {}
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const override { return map_.pixelToRobot(p, heightMm); }
  std::optional<ImageSize> imageSize() const override { return size_; }
  std::string describe() const override {
    return fmt::format("multi-height map ({} x {} points, {} segment(s) per curve)", map_.rows(), map_.cols(),
                       map_.segments());
  }

 private:
  MultiHeightMap map_;
  ImageSize size_;
};

class EyeInHandMapping final : public PixelMapping {
 public:
  explicit EyeInHandMapping(const EyeInHandPlaneMapping& m) : mapping_(m) {}
  std::optional<Vec3> pixelToRobot(PixelPoint, double) const override { return std::nullopt; }
  std::optional<ImageSize> imageSize() const override {
    return ImageSize{mapping_.camera().imageSize.width, mapping_.camera().imageSize.height};
  }
  std::string describe() const override {
    return "eye-in-hand calibration files (intrinsics, hand-eye, plane; the flange pose of each snapshot)";
  }
  const EyeInHandPlaneMapping* eyeInHand() const override { return &mapping_; }

 private:
  EyeInHandPlaneMapping mapping_;
};

}  // namespace

std::optional<Vec3> SnapshotMapping::pixelToRobot(PixelPoint p, double heightMm) const {
  return mapping_.pixelToRobot(p, heightMm, baseFromFlange_);
}
std::optional<ImageSize> SnapshotMapping::imageSize() const {
  return ImageSize{mapping_.camera().imageSize.width, mapping_.camera().imageSize.height};
}
std::string SnapshotMapping::describe() const { return "eye-in-hand snapshot"; }

std::unique_ptr<PixelMapping> eyeInHandMapping(const EyeInHandPlaneMapping& mapping) {
  return std::make_unique<EyeInHandMapping>(mapping);
}

Result<std::unique_ptr<PixelMapping>> loadCalibrationMapping(const std::string& intrinsicsPath,
                                                             const std::string& handEyePath,
                                                             const std::string& planePath) {
  // The configuration decides the mapping; any file's problem is reported in the order the
  // fixed camera's loader checks them (intrinsics, hand-eye, plane).
  auto he = readHandEye(handEyePath);
  if (he && he->config == HandEyeConfig::EyeInHand) {
    auto m = loadEyeInHandCalibration(intrinsicsPath, handEyePath, planePath);
    if (!m) return std::unexpected(m.error());
    return eyeInHandMapping(*m);
  }
  auto m = loadCellCalibration(intrinsicsPath, handEyePath, planePath);
  if (!m) return std::unexpected(m.error());
  return cameraPlaneMapping(*m);
}

std::unique_ptr<PixelMapping> pinholeMapping(const PinholePlaneModel& model) { return std::make_unique<PinholeMapping>(model); }
std::unique_ptr<PixelMapping> cameraPlaneMapping(const CameraPlaneMapping& mapping) {
  return std::make_unique<CalibratedMapping>(mapping);
}
std::unique_ptr<PixelMapping> multiHeightMapping(const MultiHeightMap& map, ImageSize imageSize) {
  return std::make_unique<MultiHeightMapping>(map, imageSize);
}

}  // namespace vgr::vision::calib
