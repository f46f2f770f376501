// A whole simulated cell as a GoogleTest fixture: the camera emulator and vgrd as child
// processes on the sim cell config (config/examples, optionally edited) in a fresh temporary
// folder, vgrd reporting READY=1 on a NOTIFY_SOCKET of ours as systemd would get it, and its
// journal read back. The cell binds the fixed loopback ports below, so two cells on one
// machine collide (ctest runs the integration tests RUN_SERIAL; people sharing a machine
// take one lock around them). The folder is kept when a test failed.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "config/cell_config.hpp"
#include "tests/support/processes.hpp"

namespace vgr::test {

class SimCell : public ::testing::Test {
 protected:
  using Clock = std::chrono::steady_clock;
  static constexpr int kModbusPort = 1502, kUrPort = 50010, kAbbPort = 50011, kFanucPort = 50012;

  static std::string bin(const std::string& name);
  // True when nothing listens on 127.0.0.1:port (another cell would take our traffic).
  static bool portFree(int port);

  // prepareCell + startCamera + startVgrd. Call as ASSERT_NO_FATAL_FAILURE(startCell()).
  // `edit` may change the YAML text before it is written (e.g. a modbus.client section).
  void startCell(const std::function<std::string(std::string)>& edit = nullptr);
  // The folder, the config (cfg_, configPath_) and the calibration files it names; fails
  // when one of the cell's ports is taken.
  void prepareCell(const std::function<std::string(std::string)>& edit = nullptr);
  // The emulator on the cell config, waited for until ready (camera.log).
  void startCamera();
  // vgrd --config --journal (vgrd.log), waited for until READY=1 (15 s).
  void startVgrd();
  // True when vgrd sends a notification containing `what` within `timeout`.
  bool waitNotify(const std::string& what, std::chrono::milliseconds timeout);

  void TearDown() override;

  std::string journalPath() const { return (dir_ / "journal.jsonl").string(); }
  // The text of a log in the cell's folder ("camera.log", "vgrd.log").
  std::string log(const std::string& name) const;
  // Every complete journal line (a line being written may be incomplete: only it may fail).
  std::vector<nlohmann::json> journal() const;
  // The journal line of cycle `cycle`, waiting up to 2 s for it to be written; null if none.
  nlohmann::json journalEntry(std::uint32_t cycle) const;

  std::filesystem::path dir_;
  std::string configPath_;
  config::CellConfig cfg_;
  std::unique_ptr<ChildProcess> camera_, vgrd_;
  std::unique_ptr<NotifySocket> notify_;

 private:
  static inline int counter_ = 0;
};

}  // namespace vgr::test
