// A whole simulated cell for the Modbus tests (modbus_vgrd_test, modbus_soak_test): the
// camera emulator and vgrd as child processes on the sim cell config (optionally edited),
// vgrd reporting READY=1 on a NOTIFY_SOCKET of ours as systemd would get it.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <modbus.h>
#include <nlohmann/json.hpp>

#include "config/cell_config.hpp"
#include "core/child_process.hpp"

namespace vgr::test {

class ModbusCell : public ::testing::Test {
 protected:
  using Clock = std::chrono::steady_clock;
  static constexpr int kModbusPort = 1502, kUrPort = 50010, kAbbPort = 50011, kFanucPort = 50012;

  static std::string bin(const std::string& name) { return std::string(VGR_BIN_DIR) + "/" + name; }

  // `edit` may change the YAML text before it is written (e.g. a modbus.client section).
  // True when nothing listens on 127.0.0.1:port (another cell would take our traffic).
  static bool portFree(int port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool taken = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(fd);
    return !taken;
  }

  // Call as ASSERT_NO_FATAL_FAILURE(startCell()).
  void startCell(const std::function<std::string(std::string)>& edit = nullptr) {
    for (const int port : {kModbusPort, kUrPort, kAbbPort, kFanucPort})
      ASSERT_TRUE(portFree(port)) << "127.0.0.1:" << port << " is taken: another cell is running on this machine";
    dir_ = std::filesystem::temp_directory_path() / ("vgr-modbus-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    std::filesystem::create_directories(dir_);
    std::string yaml = config::embeddedSimCellYaml();
    if (edit) yaml = edit(yaml);
    auto cfg = config::parseCellConfig(yaml, "cell.yaml");
    ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
    cfg_ = *cfg;
    // The config and the calibration files its `calibration` section names.
    auto written = config::writeSimCell(dir_.string(), yaml);
    ASSERT_TRUE(written.has_value()) << written.error().message;
    configPath_ = *written;
    ASSERT_NO_FATAL_FAILURE(startCamera()) << log("camera.log");
    ASSERT_NO_FATAL_FAILURE(startVgrd());
  }

  void TearDown() override {
    vgrd_.reset();
    camera_.reset();
    if (notifyFd_ >= 0) ::close(notifyFd_);
    std::error_code ec;
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(dir_, ec);
  }

  void startCamera() {
    auto p = ChildProcess::spawn({bin("vgr-sim-camera"), "--config", configPath_}, (dir_ / "camera.log").string());
    ASSERT_TRUE(p.has_value());
    ASSERT_TRUE(p->waitForLine("\"ready\"", std::chrono::milliseconds(5000)));
    camera_ = std::make_unique<ChildProcess>(std::move(*p));
  }

  void startVgrd() {
    const std::string sock = (dir_ / "notify.sock").string();
    notifyFd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un sa{};
    sa.sun_family = AF_UNIX;
    std::snprintf(sa.sun_path, sizeof sa.sun_path, "%s", sock.c_str());
    ASSERT_EQ(::bind(notifyFd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
    ::setenv("NOTIFY_SOCKET", sock.c_str(), 1);
    auto p = ChildProcess::spawn({bin("vgrd"), "--config", configPath_, "--journal", journalPath()},
                                         (dir_ / "vgrd.log").string());
    ::unsetenv("NOTIFY_SOCKET");
    ASSERT_TRUE(p.has_value());
    vgrd_ = std::make_unique<ChildProcess>(std::move(*p));
    ASSERT_TRUE(waitNotify("READY=1", std::chrono::milliseconds(15000))) << log("vgrd.log");
  }

  bool waitNotify(const std::string& what, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    timeval tv{0, 100000};
    ::setsockopt(notifyFd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    while (Clock::now() < deadline) {
      char buf[512];
      const ssize_t n = ::recv(notifyFd_, buf, sizeof buf, 0);
      if (n > 0 && std::string(buf, static_cast<std::size_t>(n)).find(what) != std::string::npos) return true;
    }
    return false;
  }

  std::string journalPath() const { return (dir_ / "journal.jsonl").string(); }
  std::string log(const std::string& name) const {
    std::ifstream in(dir_ / name);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  // Every complete journal line (a line being written may be incomplete: only it may fail).
  std::vector<nlohmann::json> journal() const {
    std::vector<nlohmann::json> out;
    std::ifstream in(journalPath());
    for (std::string line; std::getline(in, line);) {
      auto j = nlohmann::json::parse(line, nullptr, false);
      if (!j.is_discarded()) out.push_back(std::move(j));
    }
    return out;
  }

  // Counter mode: writes `triggerId` to TRIGGER_ID (HR 2; each new value triggers) and waits
  // up to `timeout` for RESULT_VALID without BUSY. Returns {STATUS, ERROR_CODE, RESULT_ID}
  // (IR 16..18); STATUS without RESULT_VALID (bit 3) when it timed out.
  struct CounterResult {
    std::uint16_t status = 0, error = 0, resultId = 0;
  };
  static CounterResult triggerCounter(modbus_t* ctx, std::uint16_t triggerId, std::chrono::milliseconds timeout) {
    CounterResult r;
    if (modbus_write_register(ctx, 2, triggerId) != 1) return r;
    std::uint16_t head[4] = {};
    const auto t = Clock::now();
    do {
      if (modbus_read_input_registers(ctx, 16, 4, head) != 4) return r;
    } while (!((head[0] & 0x08) && !(head[0] & 0x04)) && Clock::now() - t < timeout);
    return {head[0], head[1], head[2]};
  }

  // The journal line of cycle `cycle`, waiting up to 2 s for it to be written; null if none.
  nlohmann::json journalEntry(std::uint32_t cycle) const {
    for (int i = 0; i < 200; ++i) {
      for (const auto& j : journal())
        if (j["cycle"].get<std::uint32_t>() == cycle) return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return nullptr;
  }

  static inline int counter_ = 0;
  std::filesystem::path dir_;
  std::string configPath_;
  config::CellConfig cfg_;
  std::unique_ptr<ChildProcess> camera_, vgrd_;
  int notifyFd_ = -1;
};

}  // namespace vgr::test
