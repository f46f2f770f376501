// Depth frames without a camera (issue 14): the Scan3d features -> encoding (units, refusals
// naming the feature), the Coord3D_C16 -> mm conversion with invalid values and a
// confidence map, picking the parts of a multipart buffer (range + confidence, intensity
// ignored: the fake GigE camera sends single parts, so multipart is tested here), and the 3D
// data-set files (camera.yaml, truth.csv) with their file:line errors.
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <vector>

#include "config/depth_dataset.hpp"
#include "core/pose.hpp"
#include "drivers/depth_frame.hpp"

namespace vgr::drivers {
namespace {

Scan3dFeatures blaze() {
  Scan3dFeatures f;
  f.distanceUnit = "Millimeter";
  f.coordinateSystem = "Cartesian";
  f.outputMode = "RectifiedC";
  f.scale = 0.25;
  f.offset = 10.0;
  f.invalidFlag = true;
  f.invalidValue = 0.0;
  f.focalLength = 520.5;
  f.principalPointU = 319.25;
  f.principalPointV = 241.75;
  return f;
}

TEST(depth_frame, EncodingFromTheScan3dFeatures) {
  auto e = depthEncoding(blaze());
  ASSERT_TRUE(e) << e.error().message;
  EXPECT_EQ(e->scaleMm, 0.25);
  EXPECT_EQ(e->offsetMm, 10.0);
  ASSERT_TRUE(e->invalidRaw);
  EXPECT_EQ(*e->invalidRaw, 0);
  EXPECT_EQ(e->intrinsics.fx, 520.5);
  EXPECT_EQ(e->intrinsics.fy, 520.5);
  EXPECT_EQ(e->intrinsics.cx, 319.25);
  EXPECT_EQ(e->intrinsics.cy, 241.75);
  auto f = blaze();
  f.distanceUnit = "Inch";
  f.scale = 0.01;
  f.offset = 1.0;
  e = depthEncoding(f);
  ASSERT_TRUE(e);
  EXPECT_DOUBLE_EQ(e->scaleMm, 0.254);
  EXPECT_DOUBLE_EQ(e->offsetMm, 25.4);
  f = blaze();
  f.distanceUnit = "Meter";
  f.offset.reset();     // absent: 0
  f.invalidFlag = false;  // off: every raw value is data
  e = depthEncoding(f);
  ASSERT_TRUE(e);
  EXPECT_DOUBLE_EQ(e->scaleMm, 250.0);
  EXPECT_EQ(e->offsetMm, 0.0);
  EXPECT_FALSE(e->invalidRaw);
}

TEST(depth_frame, UnusableCamerasAreRefusedNamingTheFeature) {
  struct Case {
    void (*edit)(Scan3dFeatures&);
    const char* names;
  };
  const Case cases[] = {
      {[](Scan3dFeatures& f) { f.distanceUnit = "Pixel"; }, "Scan3dDistanceUnit is 'Pixel'"},
      {[](Scan3dFeatures& f) { f.distanceUnit.clear(); }, "Scan3dDistanceUnit"},
      {[](Scan3dFeatures& f) { f.coordinateSystem = "Spherical"; }, "Scan3dCoordinateSystem is 'Spherical'"},
      {[](Scan3dFeatures& f) { f.outputMode = "UncalibratedC"; }, "Scan3dOutputMode is 'UncalibratedC'"},
      {[](Scan3dFeatures& f) { f.outputMode = "DisparityC"; }, "Scan3dOutputMode is 'DisparityC'"},
      {[](Scan3dFeatures& f) { f.scale.reset(); }, "Scan3dCoordinateScale"},
      {[](Scan3dFeatures& f) { f.scale = 0.0; }, "Scan3dCoordinateScale is 0"},
      {[](Scan3dFeatures& f) { f.focalLength.reset(); }, "Scan3dFocalLength"},
      {[](Scan3dFeatures& f) { f.principalPointV.reset(); }, "Scan3dPrincipalPointU/V"},
      {[](Scan3dFeatures& f) { f.invalidValue = 70000.0; }, "Scan3dInvalidDataValue is 70000"},
  };
  for (const auto& c : cases) {
    auto f = blaze();
    c.edit(f);
    auto e = depthEncoding(f);
    ASSERT_FALSE(e) << c.names;
    EXPECT_EQ(e.error().code, Status::CameraError);
    EXPECT_NE(e.error().message.find(c.names), std::string::npos) << e.error().message;
  }
}

TEST(depth_frame, ConversionToMillimetresWithInvalidValuesAndConfidence) {
  const auto e = *depthEncoding(blaze());  // z = raw * 0.25 + 10, raw 0 = no data
  const std::vector<std::uint16_t> raw = {0, 1, 2000, 65535, 4000, 7};
  BufferPart range{reinterpret_cast<const std::uint8_t*>(raw.data()), raw.size() * 2, 3, 2, kPixelCoord3dC16, 5};
  std::vector<std::uint8_t> out;
  ASSERT_TRUE(convertDepth(range, nullptr, e, out));
  ASSERT_EQ(out.size(), 6 * sizeof(float));
  const auto* z = reinterpret_cast<const float*>(out.data());
  EXPECT_EQ(z[0], 0.0f);  // invalid
  EXPECT_EQ(z[1], 10.25f);
  EXPECT_EQ(z[2], 510.0f);
  EXPECT_EQ(z[3], 16393.75f);
  EXPECT_EQ(z[4], 1010.0f);
  // A confidence map: 0 = no data.
  const std::vector<std::uint8_t> conf = {255, 255, 0, 10, 255, 0};
  BufferPart confidence{conf.data(), conf.size(), 3, 2, kPixelConfidence8, kPartDataTypeConfidenceMap};
  ASSERT_TRUE(convertDepth(range, &confidence, e, out));
  z = reinterpret_cast<const float*>(out.data());
  EXPECT_EQ(z[1], 10.25f);
  EXPECT_EQ(z[2], 0.0f);
  EXPECT_EQ(z[3], 16393.75f);
  EXPECT_EQ(z[5], 0.0f);
  // A negative offset makes small values non-positive: no data, not a negative depth.
  auto f = blaze();
  f.offset = -1.0;
  ASSERT_TRUE(convertDepth(range, nullptr, *depthEncoding(f), out));
  EXPECT_EQ(reinterpret_cast<const float*>(out.data())[1], 0.0f);
  // Too few bytes for the size: an error, not a read past the buffer.
  BufferPart shortRange = range;
  shortRange.size = 10;
  EXPECT_FALSE(convertDepth(shortRange, nullptr, e, out));
}

TEST(depth_frame, MultipartRangeAndConfidenceArePickedIntensityIgnored) {
  std::vector<BufferPart> parts = {
      {nullptr, 0, 640, 480, 0x01100007u /* Mono16 intensity */, 1},
      {nullptr, 0, 640, 480, kPixelCoord3dC16, 5},
      {nullptr, 0, 640, 480, kPixelConfidence16, kPartDataTypeConfidenceMap},
  };
  auto d = selectDepthParts(parts);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->range, 1u);
  ASSERT_TRUE(d->confidence);
  EXPECT_EQ(*d->confidence, 2u);
  parts[2].width = 320;  // a confidence map of another size is not this range's
  d = selectDepthParts(parts);
  ASSERT_TRUE(d);
  EXPECT_FALSE(d->confidence);
  parts.erase(parts.begin() + 1);
  d = selectDepthParts(parts);
  ASSERT_FALSE(d);
  EXPECT_NE(d.error().message.find("no Coord3D_C16 range part"), std::string::npos);
}

// ---- the 3D data-set files -------------------------------------------------------------------

class depth_dataset : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("vgr-depth-file-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  std::filesystem::path dir_;
};

TEST_F(depth_dataset, CameraYamlReadAndItsErrorsNamed) {
  auto c = config::loadDepthCameraFile(
      write("camera.yaml", "width: 640\nheight: 480\nfx: 570\nfy: 571\ncx: 319.5\ncy: 239.5\ndepth_scale_mm: 0.05\n"));
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->width, 640);
  EXPECT_EQ(c->fy, 571);
  EXPECT_EQ(c->intrinsics().cx, 319.5);
  EXPECT_EQ(c->depthScaleMm, 0.05);
  auto bad = config::loadDepthCameraFile(write("bad.yaml", "width: 640\nheight: 480\nfx: 570\nfy: 570\ncx: 319.5\ncy: 239.5\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("depth_scale_mm"), std::string::npos) << bad.error().message;
  bad = config::loadDepthCameraFile(
      write("neg.yaml", "width: 640\nheight: 480\nfx: -570\nfy: 570\ncx: 319.5\ncy: 239.5\ndepth_scale_mm: 0.05\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("neg.yaml:3"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("'fx'"), std::string::npos) << bad.error().message;
  // The format is fixed: a key it does not have is named, not ignored.
  bad = config::loadDepthCameraFile(
      write("extra.yaml", "width: 640\nheight: 480\nfx: 570\nfy: 570\ncx: 319.5\ncy: 239.5\ndepth_scale_mm: 0.05\nnoise: 0.3\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("noise"), std::string::npos) << bad.error().message;
}

TEST_F(depth_dataset, TruthCsvRowsEmptyImagesAndErrors) {
  auto rows = config::loadDepthTruth(write("truth.csv",
                                              "image,x_mm,y_mm,z_mm,qw,qx,qy,qz,label\n"
                                              "images/0000.png,10,-5,480,1,0,0,0,gear\n"
                                              "images/0000.png,-40,5,470,0.7071068,0,0.7071068,0,gear\n"
                                              "images/0001.png,,,,,,,,\n"));
  ASSERT_TRUE(rows) << rows.error().message;
  ASSERT_EQ(rows->size(), 3u);
  EXPECT_EQ((*rows)[1].image, "images/0000.png");
  ASSERT_TRUE((*rows)[1].hasPart);
  EXPECT_NEAR((*rows)[1].pose.qy, 0.7071068, 1e-6);
  EXPECT_FALSE((*rows)[2].hasPart);
  auto bad = config::loadDepthTruth(write("q.csv", "image,x_mm,y_mm,z_mm,qw,qx,qy,qz\nimages/0.png,1,2,3,0.5,0,0,0\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("q.csv:2: the quaternion"), std::string::npos) << bad.error().message;
  bad = config::loadDepthTruth(write("h.csv", "image,x,y,z,qw,qx,qy,qz\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("(column 2 is 'x')"), std::string::npos) << bad.error().message;
  bad = config::loadDepthTruth(write("p.csv", "image,x_mm,y_mm,z_mm,qw,qx,qy,qz\nimages/0.png,1,,3,1,0,0,0\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("p.csv:2"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(config::listDepthImages(dir_.string()));  // no images/ folder
  std::filesystem::create_directories(dir_ / "images");
  EXPECT_FALSE(config::listDepthImages(dir_.string()));  // none in it
  write("images/0001.png", "x");
  write("images/0000.png", "x");
  write("images/notes.txt", "x");
  auto names = config::listDepthImages(dir_.string());
  ASSERT_TRUE(names) << names.error().message;
  EXPECT_EQ(*names, (std::vector<std::string>{"images/0000.png", "images/0001.png"}));
  // What writeDepthTruth writes reads back: a part row and an image's empty row.
  std::vector<config::DepthTruthRow> out{{"images/0000.png", true, poseFromQuaternion(1, -2, 480, 0.6, 0, 0.8, 0), 0},
                                         {"images/0001.png", false, Pose{}, 0}};
  ASSERT_TRUE(config::writeDepthTruth((dir_ / "w.csv").string(), out));
  auto back = config::loadDepthTruth((dir_ / "w.csv").string());
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->size(), 2u);
  EXPECT_TRUE((*back)[0].hasPart);
  EXPECT_NEAR((*back)[0].pose.z, 480, 1e-4);
  EXPECT_NEAR((*back)[0].pose.qy, 0.8, 1e-8);
  EXPECT_FALSE((*back)[1].hasPart);
}

}  // namespace
}  // namespace vgr::drivers
