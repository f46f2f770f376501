// vgrd on a cell calibrated the paper-001 way: the config's `calibration` section names a
// multiheight.yaml alone (paper 001, section 4.1: a robot-touched grid on parallel planes,
// no camera model), vgrd maps every cycle with it, and the poses in the journal match the
// renderer's ground truth. A multi-height file made for another image size answers every
// cycle with -6 NOT_CALIBRATED.
#include <cmath>
#include <filesystem>

#include "modbus_cell.hpp"
#include "sim/scene.hpp"
#include "vision/calib/multi_height_file.hpp"
#include "vision/calib/plane_model.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

class calib_multiheight_vgrd : public ModbusCell {
 protected:
  // Samples as the robot would touch them: a 15 x 15 grid at height 0 over the camera's
  // view (the example cell's camera at (400, 0, 500) mm looking down), on five planes
  // 0..40 mm, each point where the cell's camera sees it.
  std::string writeMultiHeight(int imageWidth, int imageHeight) {
    auto cell = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "sim-cell.yaml");
    EXPECT_TRUE(cell.has_value());
    const auto& m = cell->model;
    const vgr::vision::PinholePlaneModel camera(
        m.fx, m.fy, m.cx, m.cy, vgr::vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
        m.planeZ);
    vgr::vision::calib::MultiHeightSamples s;
    s.rows = 15;
    s.cols = 15;
    s.heights = {0, 10, 20, 30, 40};
    s.imageSize = {imageWidth, imageHeight};
    for (int r = 0; r < s.rows; ++r)
      for (int c = 0; c < s.cols; ++c) s.gridBase.push_back({60.0 + 680.0 * c / (s.cols - 1), -340.0 + 680.0 * r / (s.rows - 1), 0});
    for (double h : s.heights) {
      std::vector<vgr::vision::PixelPoint> plane;
      for (const auto& g : s.gridBase) {
        const auto px = camera.project({g.x, g.y, g.z + h});
        EXPECT_TRUE(px.has_value());
        plane.push_back(*px);
      }
      s.image.push_back(plane);
    }
    file_ = std::filesystem::temp_directory_path() / ("vgr-multiheight-" + std::to_string(::getpid()) + ".yaml");
    auto w = vgr::vision::calib::writeMultiHeight(file_.string(), s);
    EXPECT_TRUE(w.has_value()) << w.error().message;
    return file_.string();
  }

  // The example's calibration section replaced by `multiheight: FILE`.
  static std::string withMultiHeight(std::string yaml, const std::string& file) {
    const auto a = yaml.find("calibration:\n");
    const auto b = yaml.find("\nmodbus:", a);
    yaml.replace(a, b - a, "calibration:\n  multiheight: " + file + "\n");
    return yaml;
  }

  void TearDown() override {
    ModbusCell::TearDown();
    std::error_code ec;
    std::filesystem::remove(file_, ec);
  }

  std::filesystem::path file_;
};

TEST_F(calib_multiheight_vgrd, vgrd_maps_with_the_multi_height_map) {
  const std::string file = writeMultiHeight(1280, 1024);
  ASSERT_NO_FATAL_FAILURE(startCell([&](std::string y) { return withMultiHeight(y, file); }));
  const std::string l = log("vgrd.log");
  EXPECT_NE(l.find("mapping with multi-height map (15 x 15 points"), std::string::npos) << l;

  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  std::vector<std::uint32_t> cycles;
  for (int n = 0; n < 6; ++n) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(2000 + n), 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID";
    EXPECT_EQ(r.error, 0) << "ERROR_CODE";
    cycles.push_back(r.resultId);
  }
  modbus_close(ctx);
  modbus_free(ctx);

  const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(cfg_);
  for (const auto id : cycles) {
    const nlohmann::json entry = journalEntry(id);
    ASSERT_FALSE(entry.is_null()) << "cycle " << id;
    ASSERT_EQ(entry["status"].get<int>(), 0) << entry.dump();
    ASSERT_EQ(entry["parts"].size(), 1u) << entry.dump();
    const auto& p = entry["parts"][0];
    const auto truth = renderer.truthForFrame(entry["frame_id"].get<std::uint64_t>());
    // The map is exact for this fronto-parallel camera up to the moments' centroid error
    // (< 0.1 px = 0.05 mm at 2 px/mm); the bar is the sim cell's 0.5 mm / 0.5 deg.
    EXPECT_LT(std::hypot(p["x_mm"].get<double>() - truth.xMm, p["y_mm"].get<double>() - truth.yMm), 0.5) << entry.dump();
    EXPECT_LT(angleDiff(p["rz_deg"].get<double>(), truth.rzDeg), 0.5) << entry.dump();
    EXPECT_EQ(entry["trigger"], "modbus");
  }
}

TEST_F(calib_multiheight_vgrd, a_map_for_another_image_size_is_not_calibrated) {
  const std::string file = writeMultiHeight(640, 512);
  ASSERT_NO_FATAL_FAILURE(startCell([&](std::string y) { return withMultiHeight(y, file); }));
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  const auto r = triggerCounter(ctx, 3000, 5s);
  modbus_close(ctx);
  modbus_free(ctx);
  ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID";
  EXPECT_EQ(static_cast<std::int16_t>(r.error), -6) << "ERROR_CODE NOT_CALIBRATED";
  const std::string l = log("vgrd.log");
  EXPECT_NE(l.find("the calibration is for 640x512 px, the camera delivers 1280x1024 px"), std::string::npos) << l;
}

}  // namespace
