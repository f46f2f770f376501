#include "tools/vgr/replay.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "core/pose.hpp"
#include "core/status.hpp"
#include "daemon/cell_mapping.hpp"
#include "daemon/job_locator.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/locator.hpp"
#include "vision/part_poses.hpp"

namespace vgr::tools {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

struct Part {
  double x = 0, y = 0, z = 0, rz = 0, ry = 0, rx = 0, score = 0;
  int label = 0;
};
struct Outcome {
  int status = 0;
  std::vector<Part> parts;
};

double round3(double v) { return std::round(v * 1000.0) / 1000.0 + 0.0; }

json toJson(const Outcome& o) {
  json parts = json::array();
  for (const auto& p : o.parts)
    parts.push_back({{"x_mm", round3(p.x)}, {"y_mm", round3(p.y)}, {"z_mm", round3(p.z)}, {"rz_deg", round3(p.rz)},
                     {"ry_deg", round3(p.ry)}, {"rx_deg", round3(p.rx)}, {"score", round3(p.score)}, {"label", p.label}});
  return {{"status", o.status}, {"status_name", std::string(statusName(static_cast<Status>(o.status)))}, {"parts", parts}};
}

double angleDiff(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d > 180) d -= 360;
  if (d < -180) d += 360;
  return std::abs(d);
}

// What differs between the cell's outcome and the replay's, as short phrases ("" = the same).
std::vector<std::string> differences(const Outcome& was, const Outcome& now, double tolMm, double tolDeg) {
  std::vector<std::string> d;
  if (was.status != now.status)
    d.push_back(fmt::format("status {} {} -> {} {}", was.status, statusName(static_cast<Status>(was.status)), now.status,
                            statusName(static_cast<Status>(now.status))));
  if (was.parts.size() != now.parts.size()) d.push_back(fmt::format("parts {} -> {}", was.parts.size(), now.parts.size()));
  for (std::size_t i = 0; i < std::min(was.parts.size(), now.parts.size()); ++i) {
    const Part& a = was.parts[i];
    const Part& b = now.parts[i];
    const double dp = std::max({std::abs(a.x - b.x), std::abs(a.y - b.y), std::abs(a.z - b.z)});
    const double da = std::max({angleDiff(a.rz, b.rz), angleDiff(a.ry, b.ry), angleDiff(a.rx, b.rx)});
    if (dp > tolMm || da > tolDeg)
      d.push_back(fmt::format("part {}: moved {:.3f} mm / {:.3f} deg (x {:.3f} -> {:.3f}, y {:.3f} -> {:.3f}, rz {:.3f} -> {:.3f})",
                              i + 1, dp, da, a.x, b.x, a.y, b.y, a.rz, b.rz));
    if (a.label != b.label) d.push_back(fmt::format("part {}: label {} -> {}", i + 1, a.label, b.label));
  }
  return d;
}

Outcome fromJournal(const nlohmann::json& j) {
  Outcome o;
  o.status = j.value("status", -8);
  for (const auto& p : j.value("parts", nlohmann::json::array()))
    o.parts.push_back({p.value("x_mm", 0.0), p.value("y_mm", 0.0), p.value("z_mm", 0.0), p.value("rz_deg", 0.0), p.value("ry_deg", 0.0),
                       p.value("rx_deg", 0.0), p.value("score", 0.0), p.value("label", 0)});
  return o;
}

void progressBar(std::size_t done, std::size_t total) {
  constexpr int kWidth = 40;
  const int filled = total ? static_cast<int>(kWidth * done / total) : kWidth;
  std::fprintf(stderr, "\r[%s%s] %zu/%zu", std::string(static_cast<std::size_t>(filled), '#').c_str(),
               std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), done, total);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

bool sameFolder(const std::string& a, const std::string& b) {
  std::error_code ec1, ec2;
  const auto ca = fs::weakly_canonical(a, ec1), cb = fs::weakly_canonical(b, ec2);
  return !ec1 && !ec2 && ca == cb;
}

}  // namespace

int runReplay(const ReplayOptions& o) {
  auto job = config::loadJob(o.job);
  if (!job) return badInput(job.error().message);
  const std::string configPath = o.config.empty() ? job->calibrationPath() : o.config;
  if (configPath.empty())
    return badInput("vgr replay: needs the cell config to map pixels to the robot frame as vgrd does: --config CELL "
                    "(or a 'calibration' in " + o.job + "/job.yaml)");
  auto cell = config::loadCellConfig(configPath);
  if (!cell) return badInput(cell.error().message);
  auto mapping = daemon::makeCellMapping(*cell);
  if (!mapping) return badInput(mapping.error().message);
  auto locator = daemon::makeJobLocator(*job);
  if (!locator) return badInput(locator.error().message);
  if (!fs::is_directory(o.archive)) return badInput(o.archive + ": not a folder (the archive, archive.dir of the cell)");
  std::ifstream in(o.journal);
  if (!in) return badInput(o.journal + ": cannot open the journal");

  // Which job's frames: --job-id, else the cell job whose folder is --job, else every job.
  int jobId = o.jobId;
  const config::JobConfig* cellJob = nullptr;
  for (const auto& j : cell->jobs)
    if ((jobId != 0 && j.id == jobId) || (jobId == 0 && !j.folder.empty() && sameFolder(j.folder, o.job))) cellJob = &j;
  if (jobId == 0 && cellJob) jobId = cellJob->id;
  if (o.jobId != 0 && !cellJob) return badInput(fmt::format("{}: no job {} in the cell", configPath, o.jobId));

  vision::PartPoseRules rules;  // as CycleRunner::prepareJobs: height and reference from job.yaml, angle offset from the cell
  rules.heightMm = job->partHeightMm;
  rules.angleOffsetDeg = cellJob ? cellJob->angleOffsetDeg : 0.0;
  rules.reference = poseFromXyzRz(job->referenceXMm, job->referenceYMm, job->referenceZMm, job->referenceRzDeg * kDegToRad);

  // The archived cycles of that job, in journal order.
  std::vector<nlohmann::json> lines;
  std::set<int> jobsSeen;
  std::string text;
  int lineNo = 0;
  while (std::getline(in, text)) {
    ++lineNo;
    if (text.empty()) continue;
    auto j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_object()) return badInput(fmt::format("{}:{}: not a journal line (JSON object)", o.journal, lineNo));
    if (!j.contains("archive")) continue;
    jobsSeen.insert(j.value("job", 0));
    if (jobId != 0 && j.value("job", 0) != jobId) continue;
    lines.push_back(std::move(j));
  }
  if (jobId == 0 && jobsSeen.size() > 1)
    return badInput(fmt::format("{}: archived cycles of {} jobs and {} is none of the cell's job folders: say which with --job-id",
                                o.journal, jobsSeen.size(), o.job));

  const bool bar = o.progress || ::isatty(STDERR_FILENO);
  std::size_t missing = 0, same = 0, differ = 0, statusChanged = 0, poseChanged = 0;
  std::map<std::string, int> transitions;  // "OK -> NO_PART_FOUND": count
  json frames = json::array();
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto& j = lines[i];
    const std::string name = j.value("archive", "");
    const std::uint32_t cycle = j.value("cycle", 0u);
    if (bar) progressBar(i, lines.size());
    const fs::path png = fs::path(o.archive) / name;
    json frame{{"cycle", cycle}, {"archive", name}};
    if (!fs::exists(png)) {
      ++missing;
      frame["missing"] = true;
      if (o.all && !o.json) std::printf("cycle %u  %s: missing (deleted for the quota?)\n", cycle, name.c_str());
      if (o.all) frames.push_back(std::move(frame));
      continue;
    }
    const Outcome was = fromJournal(j);
    Outcome now;
    auto read = vision::readGray8(png.string());
    if (!read) return badInput(read.error().message);
    const cv::Mat gray = *read;
    const auto size = (*mapping)->imageSize();
    if (size && (gray.cols != size->width || gray.rows != size->height)) {
      now.status = statusCode(Status::NotCalibrated);
    } else if (auto found = (*locator)->locate(gray); !found) {
      now.status = statusCode(found.error().code);
    } else {
      for (const auto& p : vision::partPoses(found->parts, **mapping, rules)) {
        const auto e = toEulerZyxDeg(p.pose);
        now.parts.push_back({p.pose.x, p.pose.y, p.pose.z, e.rz, e.ry, e.rx, p.score, p.label});
      }
      now.status = statusCode(now.parts.empty() ? Status::NoPartFound : Status::Ok);
    }
    const auto diff = differences(was, now, o.tolMm, o.tolDeg);
    if (diff.empty()) {
      ++same;
    } else {
      ++differ;
      if (was.status != now.status) {
        ++statusChanged;
        ++transitions[fmt::format("{} -> {}", statusName(static_cast<Status>(was.status)), statusName(static_cast<Status>(now.status)))];
      } else {
        ++poseChanged;
      }
    }
    if (!o.json && (o.all || !diff.empty())) {
      std::string line = fmt::format("cycle {}  {}: ", cycle, name);
      if (diff.empty()) line += "same";
      for (std::size_t k = 0; k < diff.size(); ++k) line += (k ? "; " : "") + diff[k];
      std::printf("%s\n", line.c_str());
    }
    if (o.all || !diff.empty()) {
      frame["differs"] = !diff.empty();
      frame["differences"] = diff;
      frame["delivered"] = toJson(was);
      frame["now"] = toJson(now);
      frames.push_back(std::move(frame));
    }
  }
  if (bar) progressBar(lines.size(), lines.size());

  json summary{{"frames", lines.size()}, {"compared", same + differ}, {"same", same}, {"differ", differ},
               {"status_changed", statusChanged}, {"pose_changed", poseChanged}, {"missing", missing},
               {"transitions", transitions}, {"job", o.job}, {"job_id", jobId}};
  if (o.json) {
    std::printf("%s\n", json{{"summary", summary}, {"frames", frames}}.dump().c_str());
  } else {
    std::string t;
    for (const auto& [k, n] : transitions) t += fmt::format("{}{} x {}", t.empty() ? "" : ", ", n, k);
    std::printf("%zu archived frame(s) of job %d: %zu compared, %zu the same, %zu differ (%zu status%s%s, %zu pose), %zu missing\n",
                lines.size(), jobId, same + differ, same, differ, statusChanged, t.empty() ? "" : ": ", t.c_str(), poseChanged, missing);
  }
  return differ > 0 ? 1 : 0;
}

CLI::App* ReplayCommand::add(CLI::App& parent) {
  auto& r = options_;
  auto* cmd = parent.add_subcommand("replay", "run a (changed) job on archived frames and report what would now differ (docs/commissioning.md)");
  cmd->add_option("--journal", r.journal, "vgrd's journal (cell.journal)")->required();
  cmd->add_option("--archive", r.archive, "the image archive folder (archive.dir)")->required();
  cmd->add_option("--job", r.job, "job folder to replay (e.g. a changed copy of the cell's)")->required();
  cmd->add_option("--config", r.config, "cell config whose mapping vgrd uses (default: the job's 'calibration')");
  cmd->add_option("--job-id", r.jobId, "replay the archived cycles of this job id (default: the cell job whose folder is --job)")
      ->check(CLI::Range(1, 32767));
  cmd->add_option("--tol-mm", r.tolMm, "a pose differs beyond this, mm")->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--tol-deg", r.tolDeg, "an angle differs beyond this, deg")->check(CLI::Range(0.0, 360.0));
  cmd->add_flag("--all", r.all, "print every frame, not only those that differ");
  cmd->add_flag("--json", r.json, "one JSON object: summary and frames");
  cmd->add_flag("--progress", r.progress, "progress bar on stderr even when it is not a terminal");
  return cmd;
}

}  // namespace vgr::tools
