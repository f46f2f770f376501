#include "tools/vgr/grab.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "config/depth_dataset.hpp"
#include "drivers/aravis_camera.hpp"
#include "drivers/camera.hpp"
#include "drivers/camera_worker.hpp"
#include "vision/gray_image.hpp"

namespace vgr::tools {
namespace {

// Depth frames saved by --save: 0.1 mm per unit of the 16-bit PNGs (0 .. 6.5 m).
constexpr double kSaveDepthScaleMm = 0.1;

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

bool isIpv4(const std::string& s) {
  in_addr a{};
  return ::inet_pton(AF_INET, s.c_str(), &a) == 1;
}

// Nearest-rank percentile of sorted values; 0 for none.
double percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

}  // namespace

int runGrab(const GrabOptions& o) {
  config::CameraConfig cam;
  int deadlineMs = 1500;
  if (!o.configPath.empty()) {
    auto cfg = config::loadCellConfig(o.configPath);
    if (!cfg) {
      std::fprintf(stderr, "vgr grab: %s\n", cfg.error().message.c_str());
      return 2;
    }
    cam = cfg->camera;
    deadlineMs = cfg->cycleDeadlineMs;
  }
  if (!o.camera.empty()) {
    cam.address.clear();
    cam.serial.clear();
    cam.userName.clear();
    if (isIpv4(o.camera)) {
      cam.address = o.camera;
    } else {
      // A serial if discovery knows it, else a DeviceUserID.
      bool isSerial = false;
      for (const auto& d : drivers::discoverCameras()) isSerial = isSerial || d.serial == o.camera || d.id == o.camera;
      (isSerial ? cam.serial : cam.userName) = o.camera;
    }
  }
  if (cam.address.empty() && cam.serial.empty() && cam.userName.empty() && cam.driver == "aravis") {
    std::fprintf(stderr, "vgr grab: which camera? give --camera ID or a --config with a camera section\n");
    return 2;
  }
  if (!o.trigger.empty()) {
    if (o.trigger == "software") cam.trigger = config::TriggerMode::Software;
    else if (o.trigger == "hardware") cam.trigger = config::TriggerMode::Hardware;
    else if (o.trigger == "free_run") cam.trigger = config::TriggerMode::FreeRun;
    else {
      std::fprintf(stderr, "vgr grab: --trigger: expected software, hardware or free_run, got '%s'\n", o.trigger.c_str());
      return 2;
    }
  }
  if (!o.pixelFormat.empty()) cam.pixelFormat = o.pixelFormat;
  if (o.packetSize >= 0) cam.packetSize = o.packetSize;
  if (o.retries >= 0) cam.retries = o.retries;
  if (o.timeoutMs > 0) cam.timeoutMs = o.timeoutMs;
  if (o.deadlineMs > 0) deadlineMs = o.deadlineMs;

  auto made = drivers::makeCamera(cam);
  if (!made) {
    std::fprintf(stderr, "vgr grab: %s\n", made.error().message.c_str());
    return 2;
  }
  // Open once in the foreground: a misconfigured camera is a clear error, not a retry loop.
  if (auto r = (*made)->open(); !r) {
    std::fprintf(stderr, "vgr grab: %s\n", r.error().message.c_str());
    return 1;
  }
  (*made)->close();

  drivers::CameraWorker worker(cam, std::move(*made));
  if (!o.saveFolder.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.saveFolder, ec);
    if (ec) {
      std::fprintf(stderr, "vgr grab: --save %s: %s\n", o.saveFolder.c_str(), ec.message().c_str());
      return 2;
    }
  }
  worker.start();
  if (!worker.waitStreaming(milliseconds(15000))) {
    std::fprintf(stderr, "vgr grab: %s: not streaming after 15 s\n", worker.describe().c_str());
    return 1;
  }

  drivers::Frame frame;
  std::vector<double> latencies;
  std::map<std::string, int> errors;
  int ok = 0;
  const auto runStart = Clock::now();
  bool depthSetStarted = false;
  for (int i = 0; i < o.count; ++i) {
    const auto t0 = Clock::now();
    drivers::FrameStatus st = drivers::FrameStatus::Ok;
    auto r = worker.grab(frame, t0 + milliseconds(deadlineMs), &st);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (r && !o.saveFolder.empty() && frame.depth()) {
      // A depth camera: the frames as a 3D data set (config/depth_dataset.hpp):
      // images/frame_<id>.png in units of kSaveDepthScaleMm, camera.yaml from the first frame.
      if (!depthSetStarted) {
        config::DepthCameraFile camFile;
        camFile.width = frame.width;
        camFile.height = frame.height;
        camFile.setIntrinsics(frame.intrinsics);
        camFile.depthScaleMm = kSaveDepthScaleMm;
        std::error_code dirEc;
        std::filesystem::create_directories(std::filesystem::path(o.saveFolder) / "images", dirEc);
        if (auto w = config::writeDepthCameraFile(o.saveFolder + "/camera.yaml", camFile); !w || dirEc) {
          std::fprintf(stderr, "vgr grab: cannot write the 3D data set in %s\n", o.saveFolder.c_str());
          return 1;
        }
        depthSetStarted = true;
      }
      const cv::Mat z(frame.height, frame.width, CV_32FC1, frame.data.data());
      cv::Mat units(frame.height, frame.width, CV_16UC1);
      for (int v = 0; v < z.rows; ++v)
        for (int u = 0; u < z.cols; ++u) {
          const double q = std::round(z.at<float>(v, u) / kSaveDepthScaleMm);
          units.at<std::uint16_t>(v, u) = q > 0 && q <= 65535 ? static_cast<std::uint16_t>(q) : 0;  // beyond 6.5 m: no data
        }
      const std::string path = fmt::format("{}/images/frame_{:06d}.png", o.saveFolder, frame.frameId);
      if (!cv::imwrite(path, units)) {
        std::fprintf(stderr, "vgr grab: cannot write %s\n", path.c_str());
        return 1;
      }
    } else if (r && !o.saveFolder.empty()) {
      // Mono8 as it is; Mono10/12/16 scaled to the full 16-bit range (vision/gray_image.hpp),
      // so the tools read back exactly what vgrd locates in.
      const cv::Mat samples(frame.height, frame.width, frame.bytesPerPixel() == 2 ? CV_16UC1 : CV_8UC1, frame.data.data());
      const cv::Mat img = vision::toFullRange16(samples, frame.bitDepth);
      const std::string path = fmt::format("{}/frame_{:06d}.png", o.saveFolder, frame.frameId);
      if (!cv::imwrite(path, img)) {
        std::fprintf(stderr, "vgr grab: cannot write %s\n", path.c_str());
        return 1;
      }
    }
    if (r) {
      ++ok;
      latencies.push_back(ms);
      if (!o.json)
        std::printf("frame %d: id %llu %dx%d %d-bit, %.1f ms\n", i + 1, static_cast<unsigned long long>(frame.frameId),
                    frame.width, frame.height, frame.bitDepth, ms);
    } else {
      errors[drivers::frameStatusName(st)]++;
      if (!o.json) std::printf("frame %d: %s: %s\n", i + 1, drivers::frameStatusName(st), r.error().message.c_str());
    }
    if (o.intervalMs > 0) std::this_thread::sleep_for(milliseconds(o.intervalMs));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - runStart).count();
  worker.stop();
  const auto c = worker.counters();
  std::sort(latencies.begin(), latencies.end());
  const int errorCount = o.count - ok;
  const double p50 = percentile(latencies, 50), p99 = percentile(latencies, 99);
  if (o.json) {
    std::string byStatus;
    for (const auto& [k, v] : errors) {
      if (!byStatus.empty()) byStatus += ',';
      byStatus.append("\"").append(k).append("\":").append(std::to_string(v));
    }
    std::printf("{\"camera\":\"%s\",\"errors_by_status\":{%s},\"retries\":%llu,\"recovered\":%llu,\"reconnects\":%llu,"
                "\"missing_packets\":%llu,\"underruns\":%llu,\"seconds\":%.3f,\"p90_ms\":%.3f,\"max_ms\":%.3f}\n",
                worker.describe().c_str(), byStatus.c_str(), static_cast<unsigned long long>(c.retries),
                static_cast<unsigned long long>(c.recovered), static_cast<unsigned long long>(c.reconnects),
                static_cast<unsigned long long>(c.missingPackets), static_cast<unsigned long long>(c.underruns), seconds,
                percentile(latencies, 90), latencies.empty() ? 0.0 : latencies.back());
    std::printf("{\"frames\":%d,\"ok\":%d,\"errors\":%d,\"p50_ms\":%.3f,\"p99_ms\":%.3f}\n", o.count, ok, errorCount, p50, p99);
  } else {
    std::printf("%s: %d triggers, %d frames, %d errors", worker.describe().c_str(), o.count, ok, errorCount);
    for (const auto& [k, v] : errors) std::printf(" (%s %d)", k.c_str(), v);
    std::printf("; trigger->frame p50 %.1f ms, p99 %.1f ms; %llu re-triggers, %llu recovered, %llu missing packets\n", p50,
                p99, static_cast<unsigned long long>(c.retries), static_cast<unsigned long long>(c.recovered),
                static_cast<unsigned long long>(c.missingPackets));
  }
  std::fflush(stdout);
  return 0;
}

CLI::App* GrabCommand::add(CLI::App& parent) {
  auto& grab = options_;
  auto* grabCmd = parent.add_subcommand("grab", "trigger N frames; report frames, typed errors and trigger->frame latency");
  grabCmd->add_option("--camera", grab.camera, "IPv4 address, serial number or DeviceUserID");
  grabCmd->add_option("--config", grab.configPath, "cell config whose camera section gives the features");
  grabCmd->add_option("--count", grab.count, "number of triggers")->check(CLI::Range(1, 10000000));
  grabCmd->add_option("--trigger", grab.trigger, "software, hardware or free_run (default: the config's, else software)");
  grabCmd->add_option("--pixel-format", grab.pixelFormat, "Mono8, Mono10, Mono12, Mono16, BayerRG8, ..., Coord3D_C16");
  grabCmd->add_option("--packet-size", grab.packetSize, "GigE packet size in bytes (0 negotiates)")->check(CLI::Range(0, 65000));
  grabCmd->add_option("--retries", grab.retries, "re-triggers after a lost frame within the deadline")->check(CLI::Range(0, 10));
  grabCmd->add_option("--timeout-ms", grab.timeoutMs, "trigger -> frame timeout per attempt")->check(CLI::Range(50, 60000));
  grabCmd->add_option("--deadline-ms", grab.deadlineMs, "trigger -> frame deadline incl. re-triggers (default: cycle_deadline_ms)")->check(CLI::Range(50, 600000));
  grabCmd->add_option("--interval-ms", grab.intervalMs, "pause between triggers")->check(CLI::Range(0, 60000));
  grabCmd->add_option("--save", grab.saveFolder,
                      "write every frame received to this folder as frame_<frame id>.png (a depth camera: a 3D data set, "
                      "camera.yaml + images/, 0.1 mm per unit)");
  grabCmd->add_flag("--json", grab.json, "JSON output; the last line is {\"frames\",\"ok\",\"errors\",\"p50_ms\",\"p99_ms\"}");
  return grabCmd;
}

}  // namespace vgr::tools
