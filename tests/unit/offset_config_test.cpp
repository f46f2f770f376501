// The commissioning keys of cell.yaml (config/cell_config.hpp): robots[].deliver and
// robots[].frame, jobs[].limits, the reference offsets need, calibration.check / drift and
// the simulator's still / camera_shift / fiducial; every error names file, line and key.
// And the check vgrd --check / vgr check run on the check file (daemon/check.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "config/cell_config.hpp"
#include "daemon/check.hpp"
#include "vision/calib/check_file.hpp"

namespace {

using vgr::config::parseCellConfig;

std::string cell(const std::string& robots, const std::string& jobs, const std::string& rest = "") {
  return "camera: {address: 127.0.0.1}\nmodel: {fx: 1000}\nmodbus: {enabled: false}\nrobots:\n" + robots + "jobs:\n" + jobs + rest;
}

const std::string kJob = "  - {id: 1, reference: {x_mm: 400, y_mm: 0, z_mm: 0, rz_deg: 0}}\n";

TEST(offset_config, DeliverFrameAndLimitsAreRead) {
  auto c = parseCellConfig(cell(R"(  - {name: irb, dialect: abb, port: 50011, deliver: offset,
     frame: {name: wConveyor, x_mm: 400, y_mm: -200, z_mm: 0, rz_deg: 90}}
  - {name: ur5, port: 50010}
)",
                                R"(  - id: 1
    reference: {x_mm: 400, y_mm: 0, z_mm: 0, rz_deg: 0}
    limits:
      offset: {x_mm: [-50, 50], rz_deg: [-30, 30]}
      work_area: {x_mm: [100, 700], z_mm: [-1, 1]}
)"),
                           "cell.yaml");
  ASSERT_TRUE(c) << c.error().message;
  const auto& irb = c->robots[0];
  EXPECT_EQ(irb.delivery, vgr::config::Delivery::Offset);
  EXPECT_EQ(irb.frameName, "wConveyor");
  EXPECT_NEAR(irb.baseFromUser.x, 400, 1e-12);
  EXPECT_NEAR(irb.baseFromUser.y, -200, 1e-12);
  EXPECT_NEAR(vgr::toEulerZyxDeg(irb.baseFromUser).rz, 90, 1e-9);
  EXPECT_EQ(c->robots[1].delivery, vgr::config::Delivery::Pose);  // default
  EXPECT_EQ(c->robots[1].frameName, "base");
  const auto& l = c->jobs[0].limits;
  ASSERT_TRUE(l.offset.x && l.offset.rz && l.workArea.x && l.workArea.z);
  EXPECT_FALSE(l.offset.y || l.workArea.rz);
  EXPECT_EQ(l.offset.x->lo, -50);
  EXPECT_EQ(l.workArea.x->hi, 700);
  EXPECT_TRUE(c->jobs[0].referenceGiven);
}

TEST(offset_config, CommissioningKeysOfCalibrationAndSim) {
  auto c = parseCellConfig(cell("  - {name: ur5, port: 50010}\n", kJob, R"(calibration:
  intrinsics: i.yaml
  handeye: h.yaml
  plane: p.yaml
  check: check.yaml
  drift: {threshold_mm: 0.25, window: 7, on_alarm: refuse}
sim: {still: true, camera_shift: {x_mm: 0.5, rz_deg: 0.1}, fiducial: {x_mm: 600, y_mm: 250, diameter_mm: 12}}
)"),
                           "/cells/a/cell.yaml");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->calibration.check, "/cells/a/check.yaml");
  EXPECT_TRUE(c->calibration.drift.enabled);
  EXPECT_EQ(c->calibration.drift.thresholdMm, 0.25);
  EXPECT_EQ(c->calibration.drift.window, 7);
  EXPECT_TRUE(c->calibration.drift.refuse);
  EXPECT_TRUE(c->sim.still);
  EXPECT_EQ(c->sim.shiftXMm, 0.5);
  EXPECT_EQ(c->sim.shiftRzDeg, 0.1);
  EXPECT_EQ(c->sim.fiducialDiameterMm, 12);
}

TEST(offset_config, ErrorsNameFileLineAndKey) {
  struct Bad {
    std::string robots, jobs, rest, message;
  };
  const std::string ur = "  - {name: ur5, port: 50010}\n";
  const std::vector<Bad> bad = {
      {"  - {name: a, port: 1, deliver: offsets}\n", kJob, "",
       "cell.yaml:5: key 'robots[0].deliver': out of range: expected one of: pose, offset, got 'offsets'"},
      {"  - {name: a, port: 1, frame: {x_mm: 1}}\n", kJob, "", "cell.yaml:5: key 'robots[0].frame.name': required key is missing"},
      {"  - {name: a, port: 1, frame: {name: w, rz_deg: 400}}\n", kJob, "",
       "cell.yaml:5: key 'robots[0].frame.rz_deg': out of range: expected [-360, 360], got '400'"},
      {"  - {name: a, port: 1, frame: {name: w, rx_dg: 1}}\n", kJob, "",
       "cell.yaml:5: key 'robots[0].frame.rx_dg': unknown key (did you mean 'rx_deg'?)"},
      {"  - {name: a, port: 1, frame: {name: \"\"}}\n", kJob, "",
       "cell.yaml:5: key 'robots[0].frame.name': out of range: expected 1 to 32 printable characters, got ''"},
      // Offsets need the taught reference of every job.
      {"  - {name: a, port: 1, deliver: offset}\n", "  - {id: 1}\n", "",
       "cell.yaml:7: key 'jobs[0].reference': robots[0] ('a') delivers offsets from the job's taught reference, and job 1 "
       "has none: give `reference: {x_mm, y_mm, z_mm, rz_deg}` here"},
      {ur, "  - {id: 1, limits: {offset: {x_mm: [-5, 5]}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.offset': offset limits are relative to the job's taught reference, and job 1 has "
       "none: give `reference: {x_mm, y_mm, z_mm, rz_deg}` here"},
      {ur, "  - {id: 1, limits: {work_area: {x_mm: [5, -5]}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.work_area.x_mm': min 5 is above max -5"},
      {ur, "  - {id: 1, limits: {work_area: {x_mm: 5}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.work_area.x_mm': expected [min, max] with -1e+06 <= min <= max <= 1e+06, got '5'"},
      {ur, "  - {id: 1, limits: {work_area: {rz_deg: [-200, 0]}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.work_area.rz_deg': expected [min, max] with -180 <= min <= max <= 180, got '-200'"},
      {ur, "  - {id: 1, limits: {work_area: {rz_deg: [a, 0]}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.work_area.rz_deg': expected [min, max] with -180 <= min <= max <= 180, got 'a'"},
      {ur, "  - {id: 1, limits: {workarea: {}}}\n", "",
       "cell.yaml:7: key 'jobs[0].limits.workarea': unknown key (did you mean 'work_area'?)"},
      {ur, kJob, "calibration: {intrinsics: i, handeye: h, plane: p, drift: {}}\n",
       "cell.yaml:8: key 'calibration.drift': the drift monitor needs 'check': the file with the fiducial's stored position "
       "(vgr calibrate verify --store, docs/calibration.md)"},
      {ur, kJob, "calibration: {intrinsics: i, handeye: h, plane: p, check: c, drift: {window: 0}}\n",
       "cell.yaml:8: key 'calibration.drift.window': out of range: expected [1, 100], got '0'"},
      {ur, kJob, "calibration: {intrinsics: i, handeye: h, plane: p, check: c, drift: {on_alarm: stop}}\n",
       "cell.yaml:8: key 'calibration.drift.on_alarm': out of range: expected one of: warn, refuse, got 'stop'"},
      {ur, kJob, "sim: {fiducial: {x_mm: 1, y_mm: 2}}\n", "cell.yaml:8: key 'sim.fiducial.diameter_mm': required key is missing"},
      {ur, kJob, "sim: {camera_shift: {x_mm: 500}}\n",
       "cell.yaml:8: key 'sim.camera_shift.x_mm': out of range: expected [-100, 100], got '500'"},
  };
  for (const Bad& b : bad) {
    auto c = parseCellConfig(cell(b.robots, b.jobs, b.rest), "cell.yaml");
    ASSERT_FALSE(c) << b.robots << b.jobs << b.rest;
    EXPECT_EQ(c.error().message, b.message);
  }
}

// vgr check / vgrd --check load the check file: missing, without the fiducial the drift
// monitor needs, or naming a job the cell does not have -> exit 1 naming the key.
TEST(offset_config, CheckLoadsTheCheckFile) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("vgr-offset-config-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto writeCell = [&](const std::string& calibration) {
    std::ofstream(dir / "cell.yaml") << "cell: {journal: " << (dir / "j.jsonl").string()
                                     << "}\ncamera: {address: 127.0.0.1}\nmodel: {fx: 1000}\nmodbus: {enabled: false}\njobs:\n"
                                     << kJob << calibration;
    return (dir / "cell.yaml").string();
  };
  // The example cell's calibration files, next to a cell of our own.
  ASSERT_TRUE(vgr::config::writeSimCell(dir.string()));
  const std::string files = "calibration:\n  intrinsics: sim-calib/intrinsics.yaml\n  handeye: sim-calib/handeye.yaml\n  "
                            "plane: sim-calib/plane.yaml\n";
  EXPECT_TRUE(vgr::daemon::checkCellConfig(writeCell(files)));

  auto r = vgr::daemon::checkCellConfig(writeCell(files + "  check: check.yaml\n"));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().exitCode, 1);
  EXPECT_NE(r.error().message.find("key 'calibration.check': " + (dir / "check.yaml").string() + ": no such check file"),
            std::string::npos)
      << r.error().message;

  vgr::vision::calib::CheckFile check;
  check.part.present = true;
  check.part.job = 2;
  ASSERT_TRUE(vgr::vision::calib::writeCheckFile((dir / "check.yaml").string(), check));
  r = vgr::daemon::checkCellConfig(writeCell(files + "  check: check.yaml\n"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("part.job 2 is not a job of this cell"), std::string::npos) << r.error().message;
  r = vgr::daemon::checkCellConfig(writeCell(files + "  check: check.yaml\n  drift: {threshold_mm: 0.3}\n"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("key 'calibration.drift':"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("has no 'fiducial'"), std::string::npos) << r.error().message;

  check.part.job = 1;
  check.fiducial.present = true;
  check.fiducial.window = {10, 20, 60, 60};
  check.fiducial.positionMm = {600, 250, 0};
  ASSERT_TRUE(vgr::vision::calib::writeCheckFile((dir / "check.yaml").string(), check));
  EXPECT_TRUE(vgr::daemon::checkCellConfig(writeCell(files + "  check: check.yaml\n  drift: {threshold_mm: 0.3}\n")));
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
