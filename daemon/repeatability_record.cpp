#include "daemon/repeatability_record.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

namespace vgr::daemon {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

constexpr double kMaxMm = 1e6;    // |mean|, sigma and range of a position: within a kilometre
constexpr double kMaxDeg = 360;   // sigma and range of an angle

bool parseDouble(const std::string& text, double& out) {
  if (text.empty() || text.size() > 40) return false;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && p == end && std::isfinite(out);
}

bool parseInt(const std::string& text, int& out) {
  if (text.empty() || text.size() > 9) return false;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && p == end;
}

// Ranges and consistency, the same for the query and the file.
Result<void> check(const RepeatabilityRun& r) {
  if (r.job < 1 || r.job > 32767) return fail(Status::BadArgument, fmt::format("job: {} outside [1, 32767]", r.job));
  if (r.shots < 2 || r.shots > 100000) return fail(Status::BadArgument, fmt::format("shots: {} outside [2, 100000]", r.shots));
  if (r.found < 0 || r.failed < 0 || r.found + r.failed != r.shots)
    return fail(Status::BadArgument, fmt::format("found {} + failed {} must be shots {}", r.found, r.failed, r.shots));
  for (std::size_t k = 0; k < 6; ++k) {
    const AxisSpread& a = r.axes[k];
    const double lim = k < 3 ? kMaxMm : kMaxDeg;
    const bool meanOk = std::isfinite(a.mean) && std::abs(a.mean) <= (k < 3 ? kMaxMm : 180.0);
    if (!meanOk || !std::isfinite(a.sigma) || !std::isfinite(a.range) || a.sigma < 0 || a.range < 0 || a.sigma > lim ||
        a.range > lim)
      return fail(Status::BadArgument, fmt::format("{}: mean {}, sigma {}, range {} out of range", kRepeatabilityAxes[k],
                                                   a.mean, a.sigma, a.range));
  }
  if (!std::isfinite(r.barMm) || !std::isfinite(r.barDeg) || r.barMm < 0 || r.barDeg < 0)
    return fail(Status::BadArgument, "bar_mm, bar_deg: expected >= 0 (0: no bar)");
  // The verdict cannot contradict the figures it was made from.
  const bool over = (r.barMm > 0 && maxSigmaMm(r) > r.barMm) || (r.barDeg > 0 && maxSigmaDeg(r) > r.barDeg);
  if (r.pass && (over || r.failed > 0 || r.found < 2))
    return fail(Status::BadArgument, "pass=1 contradicts the figures (a failed shot or a sigma above the bar)");
  return {};
}

std::string isoUtc(double unixSeconds) {
  const std::time_t t = static_cast<std::time_t>(unixSeconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

double maxSigmaMm(const RepeatabilityRun& r) { return std::max({r.axes[0].sigma, r.axes[1].sigma, r.axes[2].sigma}); }
double maxSigmaDeg(const RepeatabilityRun& r) { return std::max({r.axes[3].sigma, r.axes[4].sigma, r.axes[5].sigma}); }

std::string toQuery(const RepeatabilityRun& r) {
  // fmt's "{}" of a double is its shortest form that reads back to the same value.
  std::string q = fmt::format("job={}&shots={}&found={}&failed={}", r.job, r.shots, r.found, r.failed);
  for (std::size_t k = 0; k < 6; ++k)
    q += fmt::format("&{}={},{},{}", kRepeatabilityAxes[k], r.axes[k].mean, r.axes[k].sigma, r.axes[k].range);
  q += fmt::format("&bar_mm={}&bar_deg={}&pass={}", r.barMm, r.barDeg, r.pass ? 1 : 0);
  return q;
}

Result<RepeatabilityRun> fromQuery(const std::function<std::string(const std::string&)>& param) {
  RepeatabilityRun r;
  for (auto [key, out] : {std::pair{"job", &r.job}, std::pair{"shots", &r.shots}, std::pair{"found", &r.found},
                          std::pair{"failed", &r.failed}})
    if (!parseInt(param(key), *out)) return fail(Status::BadArgument, fmt::format("{}: expected a count", key));
  for (std::size_t k = 0; k < 6; ++k) {
    const std::string v = param(kRepeatabilityAxes[k]);
    const auto c1 = v.find(',');
    const auto c2 = c1 == std::string::npos ? c1 : v.find(',', c1 + 1);
    AxisSpread& a = r.axes[k];
    if (c2 == std::string::npos || !parseDouble(v.substr(0, c1), a.mean) ||
        !parseDouble(v.substr(c1 + 1, c2 - c1 - 1), a.sigma) || !parseDouble(v.substr(c2 + 1), a.range))
      return fail(Status::BadArgument, fmt::format("{}: expected MEAN,SIGMA,RANGE", kRepeatabilityAxes[k]));
  }
  for (auto [key, out] : {std::pair{"bar_mm", &r.barMm}, std::pair{"bar_deg", &r.barDeg}})
    if (!parseDouble(param(key), *out)) return fail(Status::BadArgument, fmt::format("{}: expected a number (0: none)", key));
  const std::string pass = param("pass");
  if (pass != "0" && pass != "1") return fail(Status::BadArgument, "pass: expected 0 or 1");
  r.pass = pass == "1";
  if (auto c = check(r); !c) return std::unexpected(c.error());
  return r;
}

json toJson(const RepeatabilityRun& r) {
  json j{{"at", isoUtc(r.at)}, {"unix_time", r.at},           {"from", r.from},
         {"job", r.job},       {"shots", r.shots},            {"found", r.found},
         {"failed", r.failed}, {"pass", r.pass},              {"max_sigma_mm", maxSigmaMm(r)},
         {"max_sigma_deg", maxSigmaDeg(r)}, {"bar_mm", r.barMm}, {"bar_deg", r.barDeg}};
  for (std::size_t k = 0; k < 6; ++k)
    j[kRepeatabilityAxes[k]] = {{"mean", r.axes[k].mean}, {"sigma", r.axes[k].sigma}, {"range", r.axes[k].range}};
  return j;
}

Result<RepeatabilityRun> fromJson(const json& j) {
  try {
    RepeatabilityRun r;
    r.at = j.at("unix_time").get<double>();
    r.from = j.at("from").get<std::string>();
    r.job = j.at("job").get<int>();
    r.shots = j.at("shots").get<int>();
    r.found = j.at("found").get<int>();
    r.failed = j.at("failed").get<int>();
    r.pass = j.at("pass").get<bool>();
    r.barMm = j.at("bar_mm").get<double>();
    r.barDeg = j.at("bar_deg").get<double>();
    for (std::size_t k = 0; k < 6; ++k) {
      const json& a = j.at(kRepeatabilityAxes[k]);
      r.axes[k] = {a.at("mean").get<double>(), a.at("sigma").get<double>(), a.at("range").get<double>()};
    }
    if (!std::isfinite(r.at) || r.at < 0) return fail(Status::BadArgument, "unix_time: expected a time");
    if (auto c = check(r); !c) return std::unexpected(c.error());
    return r;
  } catch (const json::exception& e) {
    return fail(Status::BadArgument, e.what());
  }
}

std::string repeatabilityRecordPath(const std::string& journalPath) {
  return (fs::path(journalPath).parent_path() / "repeatability.json").string();
}

Result<void> writeRepeatabilityRecord(const std::string& path, const RepeatabilityRun& r) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << toJson(r).dump(2) << '\n';
    out.flush();
    if (!out) return fail(Status::Internal, fmt::format("cannot write {}", tmp));
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return fail(Status::Internal, fmt::format("cannot rename {} to {}: {}", tmp, path, ec.message()));
  return {};
}

Result<std::optional<RepeatabilityRun>> readRepeatabilityRecord(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::optional<RepeatabilityRun>{};
  const auto size = fs::file_size(path, ec);
  if (ec || size > 65536) return fail(Status::BadArgument, fmt::format("{}: not a repeatability record (size)", path));
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  const json j = json::parse(ss.str(), nullptr, false);
  if (!j.is_object()) return fail(Status::BadArgument, fmt::format("{}: not a JSON object", path));
  auto r = fromJson(j);
  if (!r) return fail(Status::BadArgument, fmt::format("{}: {}", path, r.error().message));
  return std::optional<RepeatabilityRun>{std::move(*r)};
}

}  // namespace vgr::daemon
