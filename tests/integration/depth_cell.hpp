// The simulated 3D cell as a test fixture (issue 14): config/examples/sim-cell-3d.yaml with
// rendered scenes (tools/vgr/demo3d.hpp), the depth camera emulator serving them over real
// GVSP, and vgrd. Used by depth_vgrd_test and web_page_browser_test; a test including this
// also includes "tools/vgr/demo3d.hpp" itself (the test's own includes pick its libraries).
#pragma once

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"
#include "tests/support/command.hpp"
#include "tests/support/sim_cell.hpp"
#include "tools/vgr/demo3d.hpp"

namespace vgr::test {

class DepthCell : public SimCell {
 protected:
  // The example 3D cell with `scenes` rendered scenes in dir_ (config, hand-eye, 3D job).
  void prepare3dCell(int scenes, const vgr::tools::Demo3dScenes& choice = {}, std::uint64_t seed = 3) {
    namespace fs = std::filesystem;
    for (const int port : {kModbusPort, kUrPort, kAbbPort, kFanucPort})
      ASSERT_TRUE(portFree(port)) << "127.0.0.1:" << port << " is taken: another cell is running on this machine";
    dir_ = fs::temp_directory_path() / ("vgr-cell3d-" + std::to_string(::getpid()) + "-" + std::to_string(counter3d_++));
    fs::create_directories(dir_);
    auto config = vgr::tools::prepareDemo3d(dir_.string(), scenes, seed, choice);
    ASSERT_TRUE(config) << config.error().message;
    configPath_ = *config;
    auto cfg = vgr::config::loadCellConfig(configPath_);
    ASSERT_TRUE(cfg) << cfg.error().message;
    cfg_ = *cfg;
  }
  // The depth emulator on dir_/scenes, in `unit`; then vgrd, waited for until READY=1 when
  // `waitReady` (the 3D job's model features are computed at start: up to a minute loaded).
  void start3dCell(const std::string& unit, bool waitReady) {
    camera_ = startEmulator({"--config", configPath_, "--depth", (dir_ / "scenes").string(), "--depth-unit", unit, "--truth",
                             (dir_ / "truth.jsonl").string()},
                            (dir_ / "camera.log").string(), std::chrono::milliseconds(15000));
    ASSERT_NE(camera_, nullptr);
    notify_ = std::make_unique<NotifySocket>((dir_ / "notify.sock").string());
    auto p = spawnWithNotify({bin("vgrd"), "--config", configPath_, "--journal", journalPath()}, (dir_ / "vgrd.log").string(),
                             *notify_);
    ASSERT_TRUE(p.has_value());
    vgrd_ = std::make_unique<ChildProcess>(std::move(*p));
    if (waitReady) {
      ASSERT_TRUE(waitNotify("READY=1", std::chrono::milliseconds(90000))) << log("vgrd.log");
    }
  }
  static inline int counter3d_ = 0;
};

}  // namespace vgr::test
