#include "core/log.hpp"

#include <map>
#include <mutex>
#include <string>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace vgr::log {
namespace {

std::mutex gMutex;
Level gDefault = Level::Info;
std::map<std::string, Level, std::less<>> gLevels;

spdlog::level::level_enum toSpd(Level l) {
  switch (l) {
    case Level::Trace: return spdlog::level::trace;
    case Level::Debug: return spdlog::level::debug;
    case Level::Info: return spdlog::level::info;
    case Level::Warn: return spdlog::level::warn;
    case Level::Error: return spdlog::level::err;
    case Level::Critical: return spdlog::level::critical;
    case Level::Off: return spdlog::level::off;
  }
  return spdlog::level::info;
}

// One logger per subsystem, all writing to stderr (journald picks it up under systemd).
std::shared_ptr<spdlog::logger> loggerFor(std::string_view sub) {
  const std::string name(sub);
  auto lg = spdlog::get(name);
  if (!lg) {
    lg = spdlog::stderr_color_mt(name);
    lg->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%-5l%$ [%n] %v");
    lg->set_level(spdlog::level::trace);  // filtering happens in enabled()
  }
  return lg;
}

}  // namespace

void write(std::string_view sub, Level level, std::string_view message) {
  std::shared_ptr<spdlog::logger> lg;
  {
    std::lock_guard lock(gMutex);
    lg = loggerFor(sub);
  }
  lg->log(toSpd(level), "{}", message);
}

void setLevel(std::string_view sub, Level level) {
  std::lock_guard lock(gMutex);
  gLevels[std::string(sub)] = level;
}

void setDefaultLevel(Level level) {
  std::lock_guard lock(gMutex);
  gDefault = level;
}

bool enabled(std::string_view sub, Level level) {
  std::lock_guard lock(gMutex);
  auto it = gLevels.find(sub);
  const Level threshold = it == gLevels.end() ? gDefault : it->second;
  return threshold != Level::Off && level >= threshold;
}

bool parseLevel(std::string_view t, Level& out) {
  static const std::map<std::string_view, Level> kNames = {
      {"trace", Level::Trace}, {"debug", Level::Debug}, {"info", Level::Info},
      {"warn", Level::Warn},   {"error", Level::Error}, {"critical", Level::Critical},
      {"off", Level::Off}};
  auto it = kNames.find(t);
  if (it == kNames.end()) return false;
  out = it->second;
  return true;
}

}  // namespace vgr::log
