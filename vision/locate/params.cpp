#include "vision/locate/params.hpp"

#include <charconv>
#include <cmath>

#include <fmt/core.h>

#include "core/did_you_mean.hpp"

namespace vgr::vision {

double ParamReader::number(const std::string& name, double fallback, double lo, double hi) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  const std::string& s = it->second;
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(v) || v < lo || v > hi) {
    setError(name, fmt::format("a number in [{}, {}]", lo, hi), s);
    return fallback;
  }
  return v;
}

int ParamReader::integer(const std::string& name, int fallback, int lo, int hi) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  const std::string& s = it->second;
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || v < lo || v > hi) {
    setError(name, fmt::format("an integer in [{}, {}]", lo, hi), s);
    return fallback;
  }
  return v;
}

bool ParamReader::flag(const std::string& name, bool fallback) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  if (it->second == "true") return true;
  if (it->second == "false") return false;
  setError(name, "true or false", it->second);
  return fallback;
}

std::string ParamReader::word(const std::string& name, const std::string& fallback, const std::vector<std::string>& allowed) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  for (const auto& a : allowed)
    if (it->second == a) return a;
  std::string list;
  for (std::size_t i = 0; i < allowed.size(); ++i)
    list += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ") + allowed[i];
  setError(name, list, it->second);
  return fallback;
}

void ParamReader::setError(const std::string& name, const std::string& expected, const std::string& got) {
  if (error_.empty())
    error_ = fmt::format("{}: parameter '{}': expected {}, got '{}'{}", method_, name, expected, got, whereWritten(name));
}

std::string ParamReader::whereWritten(const std::string& name) const {
  const auto it = sources_.find(name);
  if (it == sources_.end()) return "";
  return fmt::format(" ({}:{}: key 'params.{}')", it->second.file, it->second.line, name);
}

Result<void> ParamReader::finish() const {
  if (!error_.empty()) return fail(Status::BadArgument, error_);
  for (const auto& [name, value] : params_)
    if (!used_.contains(name)) {
      const std::string best = closestName(name, used_);
      return fail(Status::BadArgument, fmt::format("{}: unknown parameter '{}'{}{}", method_, name,
                                                   best.empty() ? "" : " (did you mean '" + best + "'?)", whereWritten(name)));
    }
  return {};
}

}  // namespace vgr::vision
