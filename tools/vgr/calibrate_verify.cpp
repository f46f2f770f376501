#include "tools/vgr/calibrate_verify.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"
#include "daemon/cell_mapping.hpp"
#include "tools/vgr/cell_frames.hpp"
#include "vision/calib/check_file.hpp"
#include "vision/calib/fiducial.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace {

int bad(const std::string& msg) {
  std::fprintf(stderr, "vgr calibrate verify: %s\n", msg.c_str());
  return 2;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

// Median of angles (deg) close together: unwrapped around the first.
double medianDeg(const std::vector<double>& v) {
  std::vector<double> u;
  for (double a : v) u.push_back(v.front() + std::remainder(a - v.front(), 360.0));
  return normaliseDeg(median(u));
}

struct Measured {
  int seen = 0;
  std::string lastError;
  std::vector<double> x, y, z, rz, area;
  Vec3 position() const { return {median(x), median(y), median(z)}; }
};

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

std::string nowText() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

}  // namespace

int runCalibrateVerify(const CalibVerifyOptions& o) {
  auto cfg = config::loadCellConfig(o.config);
  if (!cfg) return bad(cfg.error().message);
  const std::string checkPath = o.check.empty() ? cfg->calibration.check : o.check;
  if (checkPath.empty())
    return bad("which check file? give --check FILE or `calibration: {check: FILE}` in " + o.config);
  if (o.frames < 1 || o.frames > 1000) return bad("--frames: expected [1, 1000]");

  // What to measure: the file's targets (verify), or those the options name (store).
  calib::CheckFile check;
  if (o.store) {
    if (o.fiducialWindow.empty() && o.partJob == 0)
      return bad("--store: name what to store: --fiducial-window X,Y,W,H and/or --part-job ID");
    if (!o.fiducialWindow.empty()) {
      int v[4];
      char tail = 0;
      if (std::sscanf(o.fiducialWindow.c_str(), "%d,%d,%d,%d%c", &v[0], &v[1], &v[2], &v[3], &tail) != 4 || v[0] < 0 ||
          v[1] < 0 || v[2] < 5 || v[3] < 5)
        return bad("--fiducial-window '" + o.fiducialWindow + "': expected X,Y,WIDTH,HEIGHT in px (width, height >= 5)");
      check.fiducial.present = true;
      check.fiducial.window = cv::Rect(v[0], v[1], v[2], v[3]);
      check.fiducial.bright = !o.dark;
      check.fiducial.heightMm = o.fiducialHeightMm;
    }
    if (o.partJob != 0) {
      if (!cfg->findJob(o.partJob)) return bad(fmt::format("--part-job {}: no such job in {}", o.partJob, o.config));
      check.part.present = true;
      check.part.job = o.partJob;
    }
    check.toleranceMm = o.toleranceMm > 0 ? o.toleranceMm : 0.2;
    check.toleranceDeg = o.toleranceDeg > 0 ? o.toleranceDeg : 0.1;
  } else {
    auto c = calib::readCheckFile(checkPath);
    if (!c) return bad(c.error().message);
    check = *c;
    if (o.toleranceMm > 0) check.toleranceMm = o.toleranceMm;
    if (o.toleranceDeg > 0) check.toleranceDeg = o.toleranceDeg;
  }

  auto mapping = daemon::makeCellMapping(*cfg);
  if (!mapping) {
    std::fprintf(stderr, "vgr calibrate verify: FAIL: the calibration does not load: %s\n", mapping.error().message.c_str());
    return 1;
  }
  std::unique_ptr<CellJob> job;
  if (check.part.present) {
    auto j = makeCellJob(*cfg, check.part.job);
    if (!j) return bad(j.error().message);
    job = std::make_unique<CellJob>(std::move(*j));
  }

  auto frames = o.images.empty() ? grabCellFrames(*cfg, o.frames) : readFrames(o.images);
  if (!frames) {
    std::fprintf(stderr, "vgr calibrate verify: %s\n", frames.error().message.c_str());
    return frames.error().code == Status::BadArgument ? 2 : 1;
  }

  Measured fid, part;
  for (const cv::Mat& gray : *frames) {
    if (check.fiducial.present) {
      calib::FiducialSearch search;
      search.window = check.fiducial.window;
      search.bright = check.fiducial.bright;
      search.expectedAreaPx = o.store ? 0 : check.fiducial.areaPx;
      auto f = calib::locateFiducial(gray, search);
      if (!f) {
        fid.lastError = f.error().message;
      } else if (const auto p = (*mapping)->pixelToRobot(f->centre, check.fiducial.heightMm)) {
        ++fid.seen;
        fid.x.push_back(p->x);
        fid.y.push_back(p->y);
        fid.z.push_back(p->z);
        fid.area.push_back(f->areaPx);
      } else {
        fid.lastError = "its centre does not map onto the work plane";
      }
    }
    if (job) {
      auto parts = locateParts(*job, **mapping, gray);
      if (!parts) {
        part.lastError = parts.error().message;
      } else if (parts->empty()) {
        part.lastError = "no part found";
      } else {
        const PartResult& p = parts->front();
        ++part.seen;
        part.x.push_back(p.pose.x);
        part.y.push_back(p.pose.y);
        part.z.push_back(p.pose.z);
        part.rz.push_back(toEulerZyxDeg(p.pose).rz);
      }
    }
  }

  const std::string source = o.images.empty() ? fmt::format("{} frame(s) of {}", frames->size(), cfg->camera.name)
                                              : fmt::format("{} image(s)", frames->size());
  if (o.store) {
    if (check.fiducial.present && fid.seen == 0) {
      std::fprintf(stderr, "vgr calibrate verify: --store: fiducial not found: %s; nothing written\n", fid.lastError.c_str());
      return 1;
    }
    if (check.part.present && part.seen == 0) {
      std::fprintf(stderr, "vgr calibrate verify: --store: check part not found: %s; nothing written\n", part.lastError.c_str());
      return 1;
    }
    if (check.fiducial.present) {
      check.fiducial.positionMm = fid.position();
      check.fiducial.areaPx = median(fid.area);
    }
    if (check.part.present) {
      check.part.xMm = median(part.x);
      check.part.yMm = median(part.y);
      check.part.zMm = median(part.z);
      check.part.rzDeg = medianDeg(part.rz);
    }
    check.stored = fmt::format("vgr calibrate verify --store, {}, median of {}", nowText(), source);
    if (auto w = calib::writeCheckFile(checkPath, check); !w) return bad(w.error().message);
    nlohmann::ordered_json j{{"stored", checkPath}, {"frames", frames->size()}};
    if (check.fiducial.present) {
      const Vec3& p = check.fiducial.positionMm;
      j["fiducial_mm"] = {p.x, p.y, p.z};
      if (!o.json) std::printf("fiducial: stored at (%.3f, %.3f, %.3f) mm (seen in %d of %zu frames, %.0f px²)\n", p.x, p.y, p.z,
                               fid.seen, frames->size(), check.fiducial.areaPx);
    }
    if (check.part.present) {
      j["part"] = {check.part.xMm, check.part.yMm, check.part.zMm, check.part.rzDeg};
      if (!o.json)
        std::printf("part (job %d): stored at (%.3f, %.3f, %.3f) mm, rz %.3f deg (seen in %d of %zu frames)\n", check.part.job,
                    check.part.xMm, check.part.yMm, check.part.zMm, check.part.rzDeg, part.seen, frames->size());
    }
    if (o.json) std::printf("%s\n", j.dump().c_str());
    else std::printf("vgr calibrate verify: stored %s (tolerance %g mm / %g deg)\n", checkPath.c_str(), check.toleranceMm, check.toleranceDeg);
    return 0;
  }

  // Verify.
  int checks = 0, failed = 0;
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  if (!o.json) std::printf("vgr calibrate verify: %s against %s (%s)\n", source.c_str(), checkPath.c_str(), check.stored.c_str());
  if (check.fiducial.present) {
    ++checks;
    nlohmann::ordered_json j{{"target", "fiducial"}, {"seen", fid.seen}, {"tolerance_mm", check.toleranceMm}};
    const Vec3& s = check.fiducial.positionMm;
    j["stored_mm"] = {s.x, s.y, s.z};
    bool pass = false;
    if (fid.seen == 0) {
      j["error"] = fid.lastError;
      if (!o.json) std::printf("fiducial: NOT SEEN in %zu frame(s): %s: FAIL\n", frames->size(), fid.lastError.c_str());
    } else {
      const Vec3 m = fid.position();
      const double off = distance(m, s);
      pass = off <= check.toleranceMm;
      j["measured_mm"] = {m.x, m.y, m.z};
      j["off_mm"] = off;
      if (!o.json)
        std::printf("fiducial: at (%.3f, %.3f, %.3f) mm, stored (%.3f, %.3f, %.3f): off by %.3f mm (tolerance %g mm): %s\n", m.x,
                    m.y, m.z, s.x, s.y, s.z, off, check.toleranceMm, pass ? "PASS" : "FAIL");
    }
    j["pass"] = pass;
    failed += pass ? 0 : 1;
    out.push_back(std::move(j));
  }
  if (check.part.present) {
    ++checks;
    nlohmann::ordered_json j{{"target", "part"}, {"job", check.part.job}, {"seen", part.seen},
                             {"tolerance_mm", check.toleranceMm}, {"tolerance_deg", check.toleranceDeg}};
    j["stored"] = {check.part.xMm, check.part.yMm, check.part.zMm, check.part.rzDeg};
    bool pass = false;
    if (part.seen == 0) {
      j["error"] = part.lastError;
      if (!o.json) std::printf("part (job %d): NOT FOUND in %zu frame(s): %s: FAIL\n", check.part.job, frames->size(), part.lastError.c_str());
    } else {
      const Vec3 m = part.position();
      const double rz = medianDeg(part.rz);
      const double off = distance(m, {check.part.xMm, check.part.yMm, check.part.zMm});
      const double offDeg = angleDiffDeg(rz, check.part.rzDeg);
      pass = off <= check.toleranceMm && offDeg <= check.toleranceDeg;
      j["measured"] = {m.x, m.y, m.z, rz};
      j["off_mm"] = off;
      j["off_deg"] = offDeg;
      if (!o.json)
        std::printf("part (job %d): at (%.3f, %.3f, %.3f) mm, rz %.3f deg, stored (%.3f, %.3f, %.3f), rz %.3f: off by %.3f mm / "
                    "%.3f deg (tolerance %g mm / %g deg): %s\n",
                    check.part.job, m.x, m.y, m.z, rz, check.part.xMm, check.part.yMm, check.part.zMm, check.part.rzDeg, off,
                    offDeg, check.toleranceMm, check.toleranceDeg, pass ? "PASS" : "FAIL");
    }
    j["pass"] = pass;
    failed += pass ? 0 : 1;
    out.push_back(std::move(j));
  }
  if (o.json) {
    nlohmann::ordered_json j{{"pass", failed == 0}, {"frames", frames->size()}, {"checks", std::move(out)}};
    std::printf("%s\n", j.dump().c_str());
  } else if (failed == 0) {
    std::printf("vgr calibrate verify: PASS (%d check(s))\n", checks);
  } else {
    std::printf("vgr calibrate verify: FAIL (%d of %d check(s)): the calibration no longer maps as it did; check the camera "
                "mount and lens, then recalibrate (docs/calibration.md)\n",
                failed, checks);
  }
  return failed == 0 ? 0 : 1;
}

CLI::App* CalibrateVerifyCommand::add(CLI::App& parent) {
  auto& v = options_;
  auto* c = parent.add_subcommand("verify", "check the calibration against stored check targets (fiducial, check part)");
  c->add_option("--config", v.config, "cell config (its mapping, camera, jobs and calibration.check)")->required();
  c->add_option("--image", v.images, "frames to measure in (files or globs; default: grab --frames from the cell's camera)");
  c->add_option("--frames", v.frames, "frames to grab; the median counts")->capture_default_str();
  c->add_option("--check", v.check, "the check file (default: the config's calibration.check)");
  c->add_flag("--store", v.store, "measure the targets named below and write the check file");
  c->add_option("--fiducial-window", v.fiducialWindow, "--store: X,Y,WIDTH,HEIGHT px where the fiducial is searched");
  c->add_option("--fiducial-height", v.fiducialHeightMm, "--store: the fiducial's height above the work plane, mm");
  c->add_flag("--dark", v.dark, "--store: the fiducial is dark on a bright ground");
  c->add_option("--part-job", v.partJob, "--store: a check part of this job lies at its place")->check(CLI::Range(1, 32767));
  c->add_option("--tolerance-mm", v.toleranceMm, "pass within this distance, mm (stored; default 0.2)")->check(CLI::PositiveNumber);
  c->add_option("--tolerance-deg", v.toleranceDeg, "pass within this angle, deg (stored; default 0.1)")->check(CLI::PositiveNumber);
  c->add_flag("--json", v.json, "one JSON line");
  return c;
}

}  // namespace vgr::tools
