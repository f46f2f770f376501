#include "tests/support/sim_cell.hpp"

#include <unistd.h>

#include <fstream>
#include <iterator>
#include <thread>

#include "tests/support/command.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace vgr::test {

std::string SimCell::bin(const std::string& name) { return binPath(name); }

bool SimCell::portFree(int port) { return loopbackPortFree(static_cast<std::uint16_t>(port)); }

void SimCell::startCell(const std::function<std::string(std::string)>& edit) {
  ASSERT_NO_FATAL_FAILURE(prepareCell(edit));
  ASSERT_NO_FATAL_FAILURE(startCamera()) << log("camera.log");
  ASSERT_NO_FATAL_FAILURE(startVgrd());
}

void SimCell::prepareCell(const std::function<std::string(std::string)>& edit) {
  for (const int port : {kModbusPort, kUrPort, kAbbPort, kFanucPort})
    ASSERT_TRUE(portFree(port)) << "127.0.0.1:" << port << " is taken: another cell is running on this machine";
  dir_ = std::filesystem::temp_directory_path() / ("vgr-cell-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
  std::filesystem::create_directories(dir_);
  std::string yaml = config::embeddedSimCellYaml();
  if (edit) yaml = edit(yaml);
  auto cfg = config::parseCellConfig(yaml, "cell.yaml");
  ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
  cfg_ = *cfg;
  auto written = config::writeSimCell(dir_.string(), yaml);  // + its calibration files
  ASSERT_TRUE(written.has_value()) << written.error().message;
  configPath_ = *written;
}

void SimCell::startCamera() {
  camera_ = startEmulator({"--config", configPath_}, (dir_ / "camera.log").string());
  ASSERT_NE(camera_, nullptr);
}

void SimCell::startVgrd() {
  // A second start: the old socket goes first (its destructor unlinks the path the new one binds).
  notify_.reset();
  notify_ = std::make_unique<NotifySocket>((dir_ / "notify.sock").string());
  ASSERT_TRUE(notify_->ok()) << notify_->path();
  auto p = spawnWithNotify({bin("vgrd"), "--config", configPath_, "--journal", journalPath()}, (dir_ / "vgrd.log").string(),
                           *notify_);
  ASSERT_TRUE(p.has_value());
  vgrd_ = std::make_unique<ChildProcess>(std::move(*p));
  ASSERT_TRUE(waitNotify("READY=1", std::chrono::milliseconds(15000))) << log("vgrd.log");
}

bool SimCell::waitNotify(const std::string& what, std::chrono::milliseconds timeout) {
  return notify_ != nullptr && notify_->waitFor(what, timeout);
}

void SimCell::TearDown() {
  vgrd_.reset();
  camera_.reset();
  notify_.reset();
  std::error_code ec;
  if (!dir_.empty() && !::testing::Test::HasFailure()) std::filesystem::remove_all(dir_, ec);
}

std::string SimCell::log(const std::string& name) const {
  std::ifstream in(dir_ / name);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<nlohmann::json> SimCell::journal() const {
  std::vector<nlohmann::json> out;
  std::ifstream in(journalPath());
  for (std::string line; std::getline(in, line);) {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (!j.is_discarded()) out.push_back(std::move(j));
  }
  return out;
}

nlohmann::json SimCell::journalEntry(std::uint32_t cycle) const {
  const auto deadline = Clock::now() + std::chrono::milliseconds(2000);
  do {
    for (const auto& j : journal())
      if (j.contains("cycle") && j["cycle"].get<std::uint32_t>() == cycle) return j;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  } while (Clock::now() < deadline);
  return nullptr;
}

}  // namespace vgr::test
