// The fixed fiducial of the calibration checks (vision/calib/fiducial.hpp), the check file
// (vision/calib/check_file.hpp) and vgrd's drift monitor (daemon/drift_monitor.hpp) on
// frames of the simulated cell's renderer with its fiducial (sim.fiducial), the camera in
// place and knocked away by sim.camera_shift, mapped with the cell's pinhole model.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "config/cell_config.hpp"
#include "daemon/drift_monitor.hpp"
#include "sim/scene.hpp"
#include "vision/calib/check_file.hpp"
#include "vision/calib/fiducial.hpp"
#include "vision/calib/pixel_mapping.hpp"

namespace vgr {
namespace {

namespace calib = vision::calib;

config::CellConfig simCell(double shiftX = 0, double diameter = 12) {
  auto c = config::parseCellConfig(config::embeddedSimCellYaml(), "sim-cell.yaml");
  EXPECT_TRUE(c);
  c->sim.fiducialXMm = 600;
  c->sim.fiducialYMm = 250;
  c->sim.fiducialDiameterMm = diameter;
  c->sim.shiftXMm = shiftX;
  return *c;
}

vision::PinholePlaneModel nominal(const config::CellConfig& c) {
  const auto& m = c.model;
  return vision::PinholePlaneModel(m.fx, m.fy, m.cx, m.cy, vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                   m.planeZ);
}

// The search window: 80 px around where the nominal camera sees the fiducial.
cv::Rect windowOf(const config::CellConfig& c) {
  const auto px = nominal(c).project({c.sim.fiducialXMm, c.sim.fiducialYMm, 0});
  return {static_cast<int>(px->u) - 40, static_cast<int>(px->v) - 40, 80, 80};
}

TEST(fiducial, FoundToAHundredthOfAMillimetreAndMovesWithTheCamera) {
  const auto cell = simCell();
  const auto mapping = calib::pinholeMapping(nominal(cell));
  calib::FiducialSearch search;
  search.window = windowOf(cell);
  for (double shift : {0.0, 0.5}) {
    const auto renderer = sim::SceneRenderer::fromCellConfig(simCell(shift));
    double worst = 0, mean = 0;
    for (std::uint64_t frame = 1; frame <= 10; ++frame) {
      cv::Mat img;
      renderer.render(frame, img);
      auto f = calib::locateFiducial(img, search);
      ASSERT_TRUE(f) << "frame " << frame << ": " << f.error().message;
      EXPECT_NEAR(f->diameterPx, 24.0, 1.0);  // 12 mm at 0.5 mm/px
      const auto p = mapping->pixelToRobot(f->centre, 0);
      ASSERT_TRUE(p);
      const double d = std::hypot(p->x - 600, p->y - 250);
      worst = std::max(worst, std::abs(d - shift));
      mean += d / 10;
    }
    // In place: within 0.01 mm of where it is; the camera moved 0.5 mm: 0.5 mm off.
    EXPECT_LT(worst, 0.01) << "shift " << shift;
    EXPECT_NEAR(mean, shift, 0.01);
  }
}

TEST(fiducial, NotSeenAmbiguousOrCutIsAnError) {
  const auto cell = simCell();
  calib::FiducialSearch search;
  search.window = windowOf(cell);
  cv::Mat img;
  sim::SceneRenderer::fromCellConfig(simCell(0, 0)).render(1, img);  // no fiducial
  auto f = calib::locateFiducial(img, search);
  ASSERT_FALSE(f);
  EXPECT_EQ(f.error().message, "fiducial not seen in its search window");
  sim::SceneRenderer::fromCellConfig(cell).render(1, img);
  // A second round mark in the window.
  cv::circle(img, {search.window.x + 12, search.window.y + 12}, 6, cv::Scalar(230), cv::FILLED, cv::LINE_AA);
  f = calib::locateFiducial(img, search);
  ASSERT_FALSE(f);
  EXPECT_EQ(f.error().message, "fiducial ambiguous: 2 round marks in its search window");
  // A window that cuts the mark.
  sim::SceneRenderer::fromCellConfig(cell).render(1, img);
  search.window.x += 45;
  EXPECT_FALSE(calib::locateFiducial(img, search));
  // The expected area (as stored) rejects a mark of another size.
  search = calib::FiducialSearch{};
  search.window = windowOf(cell);
  search.expectedAreaPx = 4 * 450.0;
  EXPECT_FALSE(calib::locateFiducial(img, search));
  search.window = {-500, -500, 10, 10};
  EXPECT_EQ(calib::locateFiducial(img, search).error().code, Status::BadArgument);
}

TEST(fiducial, CheckFileRoundTripAndErrors) {
  namespace fs = std::filesystem;
  const std::string path = (fs::temp_directory_path() / ("vgr-check-" + std::to_string(::getpid()) + ".yaml")).string();
  calib::CheckFile c;
  c.toleranceMm = 0.15;
  c.fiducial.present = true;
  c.fiducial.window = {100, 120, 80, 80};
  c.fiducial.bright = false;
  c.fiducial.heightMm = 3.5;
  c.fiducial.positionMm = {600.125, 249.875, 3.5};
  c.fiducial.areaPx = 451;
  c.part.present = true;
  c.part.job = 3;
  c.part.xMm = 412.5;
  c.part.rzDeg = -33.25;
  c.stored = "by hand";
  ASSERT_TRUE(calib::writeCheckFile(path, c));
  auto r = calib::readCheckFile(path);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->toleranceMm, 0.15);
  EXPECT_EQ(r->fiducial.window, cv::Rect(100, 120, 80, 80));
  EXPECT_FALSE(r->fiducial.bright);
  EXPECT_EQ(r->fiducial.positionMm.x, 600.125);
  EXPECT_EQ(r->fiducial.areaPx, 451);
  EXPECT_EQ(r->part.job, 3);
  EXPECT_EQ(r->part.rzDeg, -33.25);
  EXPECT_EQ(r->stored, "by hand");

  c.fiducial.present = false;
  c.part.present = false;
  ASSERT_TRUE(calib::writeCheckFile(path, c));
  EXPECT_EQ(calib::readCheckFile(path).error().message, path + ": neither 'fiducial' nor 'part': nothing to check");
  c.part.present = true;
  c.part.job = 0;
  ASSERT_TRUE(calib::writeCheckFile(path, c));
  EXPECT_EQ(calib::readCheckFile(path).error().message, path + ": key 'part.job': expected a number in [1, 32767], got 0");
  EXPECT_EQ(calib::readCheckFile(path + ".none").error().message, path + ".none: no such check file");
  std::error_code ec;
  fs::remove(path, ec);
}

// The drift monitor on rendered frames: no alarm in place; the camera knocked 0.5 mm raises
// it on the third frame (median of at least 3); back in place clears it; a fiducial not
// seen for `window` frames raises it too.
TEST(fiducial, DriftMonitorAlarmsOnAKnockedCameraAndAMissingMark) {
  const auto cell = simCell();
  const auto mapping = calib::pinholeMapping(nominal(cell));
  calib::CheckFile::Fiducial f;
  f.present = true;
  f.window = windowOf(cell);
  f.positionMm = {600, 250, 0};
  f.areaPx = 452;
  config::CalibrationFilesConfig::Drift cfg;
  cfg.enabled = true;
  cfg.thresholdMm = 0.3;
  cfg.window = 5;
  daemon::DriftMonitor monitor(cfg, f);
  std::uint64_t frame = 0;
  auto cycle = [&](const config::CellConfig& c) {
    cv::Mat img;
    sim::SceneRenderer::fromCellConfig(c).render(++frame, img);
    CycleResult r;
    r.cycleId = static_cast<std::uint32_t>(frame);
    monitor.measure(img, *mapping, r);
    EXPECT_TRUE(r.driftMonitored);
    return r;
  };
  for (int i = 0; i < 6; ++i) {
    const auto r = cycle(cell);
    EXPECT_LT(r.driftMm, 0.02);
    EXPECT_FALSE(r.driftAlarm);
  }
  const auto knocked = simCell(0.5);
  int firstAlarm = 0;
  for (int i = 1; i <= 6; ++i) {
    const auto r = cycle(knocked);
    EXPECT_NEAR(r.driftMm, 0.5, 0.02);
    if (r.driftAlarm && !firstAlarm) firstAlarm = i;
  }
  EXPECT_EQ(firstAlarm, 3);  // the median of 5 turns on the third knocked frame
  EXPECT_NE(monitor.reason().find("above 0.3 mm"), std::string::npos) << monitor.reason();
  for (int i = 0; i < 5; ++i) cycle(cell);
  EXPECT_FALSE(monitor.alarm());
  const auto bare = simCell(0, 0);
  for (int i = 1; i <= 5; ++i) {
    const auto r = cycle(bare);
    EXPECT_TRUE(std::isnan(r.driftMm));
    EXPECT_EQ(r.driftAlarm, i == 5) << i;
  }
  EXPECT_NE(monitor.reason().find("fiducial not seen in 5 frames in a row"), std::string::npos) << monitor.reason();
}

}  // namespace
}  // namespace vgr
