// Logging by subsystem (STYLE.md rule 12) behind a thin header: spdlog's headers cost
// seconds per translation unit, so only core/log.cpp includes them.
// Thread-safe; callable from any thread. Nothing should log at info per frame.
#pragma once

#include <string>
#include <string_view>
#include <utility>

#include <fmt/core.h>

namespace vgr::log {

enum class Level { Trace, Debug, Info, Warn, Error, Critical, Off };

// Subsystems: "main", "camera", "modbus", "robot", "vision", "cycle", "sim".
void write(std::string_view subsystem, Level level, std::string_view message);
void setLevel(std::string_view subsystem, Level level);
void setDefaultLevel(Level level);
bool enabled(std::string_view subsystem, Level level);
// Parse "trace|debug|info|warn|error|critical|off"; false when unknown.
bool parseLevel(std::string_view text, Level& out);

template <class... Args>
void info(std::string_view sub, fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(sub, Level::Info)) write(sub, Level::Info, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void warn(std::string_view sub, fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(sub, Level::Warn)) write(sub, Level::Warn, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void error(std::string_view sub, fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(sub, Level::Error)) write(sub, Level::Error, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void debug(std::string_view sub, fmt::format_string<Args...> f, Args&&... args) {
  if (enabled(sub, Level::Debug)) write(sub, Level::Debug, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace vgr::log
