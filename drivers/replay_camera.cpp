#include "drivers/replay_camera.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/depth_dataset.hpp"

namespace vgr::drivers {
namespace {

namespace fs = std::filesystem;

std::uint64_t wallNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

bool isImage(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* x : {".png", ".pgm", ".pnm", ".ppm", ".tif", ".tiff", ".bmp", ".jpg", ".jpeg"})
    if (e == x) return true;
  return false;
}

class ReplayCamera final : public Camera {
 public:
  explicit ReplayCamera(config::CameraConfig c) : cfg_(std::move(c)) {}

  std::string describe() const override { return "camera '" + cfg_.name + "' (replay " + cfg_.replayFolder + ")"; }
  CameraState state() const override { return state_; }
  FrameStatus lastFrameStatus() const override { return lastStatus_; }
  bool controlLost() const override { return false; }
  CameraStats stats() const override { return stats_; }

  Result<void> open() override {
    if (state_ != CameraState::Closed) return fail(Status::Internal, describe() + ": open() while not closed");
    if (cfg_.trigger == config::TriggerMode::FreeRun)
      return fail(Status::CameraError, describe() + ": camera.trigger.mode: free_run is not supported by the replay camera");
    depth_ = cfg_.pixelFormat == "Coord3D_C16";
    if (cfg_.pixelFormat.rfind("Mono", 0) != 0 && !depth_)
      return fail(Status::CameraError, describe() + ": camera.pixel_format: '" + cfg_.pixelFormat + "' is not supported by the replay camera (Mono8..Mono16, Coord3D_C16)");
    std::error_code ec;
    if (!fs::is_directory(cfg_.replayFolder, ec))
      return fail(Status::CameraError, describe() + ": camera.replay.folder: '" + cfg_.replayFolder + "' is not a folder");
    files_.clear();
    if (depth_) return openDepthSet();
    for (const auto& e : fs::directory_iterator(cfg_.replayFolder, ec))
      if (e.is_regular_file() && isImage(e.path())) files_.push_back(e.path());
    if (ec) return fail(Status::CameraError, describe() + ": cannot list the folder: " + ec.message());
    std::sort(files_.begin(), files_.end());
    if (files_.empty()) return fail(Status::CameraError, describe() + ": camera.replay.folder: no images (png, pgm, tiff, bmp, jpg) in '" + cfg_.replayFolder + "'");
    state_ = CameraState::Open;
    return {};
  }

  void close() override {
    files_.clear();
    state_ = CameraState::Closed;
  }

  Result<void> start() override {
    if (state_ != CameraState::Open) return fail(Status::Internal, describe() + ": start() while not open");
    state_ = CameraState::Streaming;
    return {};
  }

  void stop() override {
    if (state_ == CameraState::Streaming) state_ = CameraState::Open;
  }

  Result<void> triggerAndWait(Frame& out, std::chrono::milliseconds timeout) override {
    if (state_ != CameraState::Streaming) return failWith(FrameStatus::IllegalState, "trigger while not streaming");
    if (cfg_.trigger == config::TriggerMode::Hardware) {
      std::this_thread::sleep_for(timeout);  // no line to fire: the frame never comes
      return failWith(FrameStatus::Timeout, "no hardware trigger within " + std::to_string(timeout.count()) + " ms");
    }
    if (next_ >= files_.size() && !cfg_.replayLoop) return failWith(FrameStatus::EndOfStream, "no more images (replay.loop is off)");
    const fs::path& path = files_[next_ % files_.size()];
    std::error_code ec;
    if (!fs::exists(path, ec)) return failWith(FrameStatus::Disconnected, "image " + path.string() + " vanished");
    cv::Mat img = cv::imread(path.string(), depth_ ? cv::IMREAD_UNCHANGED : cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
    if (img.empty()) return failWith(FrameStatus::Failed, "cannot decode " + path.string());
    if (depth_) return serveDepth(img, path, out);
    if (img.channels() == 3) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
    if (img.channels() == 4) cv::cvtColor(img, img, cv::COLOR_BGRA2GRAY);
    const bool wide = cfg_.pixelFormat != "Mono8";
    const int bits = cfg_.pixelFormat == "Mono10" ? 10 : cfg_.pixelFormat == "Mono12" ? 12 : wide ? 16 : 8;
    // Convert the file's depth to the configured one (8 <-> 16 bit by scaling).
    if (wide && img.depth() == CV_8U) img.convertTo(img, CV_16U, (1 << bits) / 256.0);
    if (!wide && img.depth() == CV_16U) img.convertTo(img, CV_8U, 1.0 / 256.0);
    if (img.depth() != CV_8U && img.depth() != CV_16U) return failWith(FrameStatus::Failed, path.string() + ": unsupported image depth");
    out.width = img.cols;
    out.height = img.rows;
    out.pixel = wide ? PixelType::Mono16 : PixelType::Mono8;
    out.bitDepth = bits;
    const size_t rowBytes = static_cast<size_t>(img.cols) * img.elemSize();
    out.data.resize(rowBytes * img.rows);
    for (int y = 0; y < img.rows; ++y) std::memcpy(out.data.data() + y * rowBytes, img.ptr(y), rowBytes);
    return served(out);
  }

 private:
  // A 3D data-set folder (config/depth_dataset.hpp): camera.yaml and images/*.png.
  Result<void> openDepthSet() {
    auto cam = config::loadDepthCameraFile((fs::path(cfg_.replayFolder) / "camera.yaml").string());
    if (!cam) return fail(Status::CameraError, describe() + ": camera.replay.folder (a 3D data set for Coord3D_C16): " + cam.error().message);
    auto images = config::listDepthImages(cfg_.replayFolder);
    if (!images) return fail(Status::CameraError, describe() + ": camera.replay.folder: " + images.error().message);
    camera_ = *cam;
    for (const auto& i : *images) files_.push_back(fs::path(cfg_.replayFolder) / i);
    state_ = CameraState::Open;
    return {};
  }

  // z = value * depth_scale_mm, 0 = no data, with camera.yaml's intrinsics.
  Result<void> serveDepth(const cv::Mat& img, const fs::path& path, Frame& out) {
    if (img.type() != CV_16UC1)
      return failWith(FrameStatus::Failed, path.string() + ": not a 16-bit single-channel depth image (" +
                                               std::to_string(img.channels()) + " channel(s), " +
                                               (img.depth() == CV_8U ? "8" : img.depth() == CV_16U ? "16" : "other") + "-bit)");
    if (img.cols != camera_.width || img.rows != camera_.height)
      return failWith(FrameStatus::Failed, path.string() + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                                               " px, camera.yaml says " + std::to_string(camera_.width) + "x" +
                                               std::to_string(camera_.height));
    out.width = img.cols;
    out.height = img.rows;
    out.pixel = PixelType::DepthMm;
    out.bitDepth = 32;
    out.intrinsics = camera_.intrinsics();
    out.data.resize(static_cast<std::size_t>(img.cols) * img.rows * sizeof(float));
    cv::Mat z(img.rows, img.cols, CV_32FC1, out.data.data());
    img.convertTo(z, CV_32F, camera_.depthScaleMm);  // 0 stays 0: no data
    return served(out);
  }

  // A frame handed out: its id and time, and the counters.
  Result<void> served(Frame& out) {
    ++next_;
    out.frameId = next_;
    out.deviceTimestampNs = 0;
    out.hostTimestampNs = wallNs();
    lastStatus_ = FrameStatus::Ok;
    stats_.completed++;
    return {};
  }

  Result<void> failWith(FrameStatus s, const std::string& what) {
    lastStatus_ = s;
    if (s != FrameStatus::IllegalState) {
      stats_.failed++;
      if (s == FrameStatus::Timeout) stats_.timeouts++;
    }
    return fail(s == FrameStatus::IllegalState ? Status::Internal : Status::CameraError,
                describe() + ": " + what + " (" + frameStatusName(s) + ")");
  }

  config::CameraConfig cfg_;
  std::vector<fs::path> files_;
  std::size_t next_ = 0;  // images served since construction (the position survives reopen)
  bool depth_ = false;     // Coord3D_C16: the folder is a 3D data set
  config::DepthCameraFile camera_;  // its camera.yaml
  CameraState state_ = CameraState::Closed;
  FrameStatus lastStatus_ = FrameStatus::Ok;
  CameraStats stats_;
};

}  // namespace

std::unique_ptr<Camera> makeReplayCamera(const config::CameraConfig& config) {
  return std::make_unique<ReplayCamera>(config);
}

}  // namespace vgr::drivers
