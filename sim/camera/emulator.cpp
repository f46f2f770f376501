#include "sim/camera/emulator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include <arv.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fmt/format.h>

#include "config/depth_dataset.hpp"
#include "core/log.hpp"
#include "sim/camera/depth_xml.hpp"

namespace vgr::sim {

struct CameraEmulator::Impl {
  CellScenes scenes;
  EmulatorOptions options;
  ArvGvFakeCamera* camera = nullptr;
  cv::Mat frame, frame16;  // reused render targets (camera thread)
  std::vector<cv::Mat> images;      // image-folder mode: CV_8UC1 or CV_16UC1, all one size
  int width = 0, height = 0;        // sensor size
  std::atomic<std::uint64_t> served{0};
  std::FILE* truth = nullptr;
  std::mutex lineMutex;
  // Depth camera: the data set's images (CV_16UC1), their names and truth.
  bool depthMode = false;
  config::DepthCameraFile depthCamera;
  std::vector<cv::Mat> depthImages;
  std::vector<std::string> depthNames;
  std::map<std::string, std::vector<Pose>> depthTruth;  // by image name; an image without a part: none

  Impl(CellScenes s, EmulatorOptions o) : scenes(std::move(s)), options(std::move(o)) {}

  // The full-sensor image of frame `frameId` at `depth` (CV_8U or CV_16U), and its truth.
  const cv::Mat& source(std::uint64_t frameId, int depth, std::vector<CellPartTruth>& t, bool& hasTruth) {
    if (!images.empty()) {
      hasTruth = false;
      const cv::Mat& img = images[(frameId + images.size() - 1) % images.size()];
      if (img.depth() == depth) return img;
      cv::Mat& dst = depth == CV_16U ? frame16 : frame;
      if (depth == CV_16U)
        img.convertTo(dst, CV_16U, 257.0);
      else
        img.convertTo(dst, CV_8U, 1.0 / 257.0);
      return dst;
    }
    hasTruth = true;
    t = scenes.render(frameId, frame);
    if (options.emptyEvery > 0 && frameId % static_cast<std::uint64_t>(options.emptyEvery) == 0) {
      // The empty belt: the frame's background level (its median: the parts cover little of
      // it) with the same kind of sensor noise, deterministic per frame id.
      int hist[256] = {};
      for (int r = 0; r < frame.rows; ++r)
        for (const uchar* p = frame.ptr(r); p != frame.ptr(r) + frame.cols; ++p) ++hist[*p];
      int level = 0;
      for (std::size_t seen = 0; level < 255 && (seen += static_cast<std::size_t>(hist[level])) < frame.total() / 2; ++level) {
      }
      cv::RNG rng(frameId);
      cv::Mat noise(frame.size(), CV_16SC1);
      rng.fill(noise, cv::RNG::NORMAL, level, 2.0);
      noise.convertTo(frame, CV_8U);
      t.clear();
    }
    if (depth != CV_16U) return frame;
    frame.convertTo(frame16, CV_16U, 257.0);  // 8-bit level v as v * 257: full scale 65535
    return frame16;
  }

  // The depth frame `frameId` (Coord3D_C16: the data set's 16-bit values, little-endian).
  void fillDepth(std::uint8_t* out, std::uint64_t frameId, int x, int y, int w, int h, ArvPixelFormat format) {
    if (format != ARV_PIXEL_FORMAT_COORD3D_C_16) {
      log::warn("sim", "fill: the depth camera serves Coord3D_C16 only, not pixel format 0x{:x}", static_cast<unsigned>(format));
      return;
    }
    const std::size_t index = (frameId + depthImages.size() - 1) % depthImages.size();
    const cv::Mat& src = depthImages[index];
    const std::size_t row = static_cast<std::size_t>(w) * 2;
    for (int r = 0; r < h; ++r) std::memcpy(out + r * row, src.ptr(y + r) + static_cast<std::size_t>(x) * 2, row);
    served++;
    if (!truth) return;
    std::string parts;
    for (const Pose& p : depthTruth[depthNames[index]])
      parts += fmt::format("{}{{\"x_mm\":{:.4f},\"y_mm\":{:.4f},\"z_mm\":{:.4f},\"qw\":{:.9f},\"qx\":{:.9f},\"qy\":{:.9f},\"qz\":{:.9f}}}",
                           parts.empty() ? "" : ",", p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz);
    std::fprintf(truth, "{\"frame_id\":%llu,\"image\":\"%s\",\"parts\":[%s]}\n", static_cast<unsigned long long>(frameId),
                 depthNames[index].c_str(), parts.c_str());
    std::fflush(truth);
  }

  // The data set: camera.yaml, every image (16-bit, camera.yaml's size), truth.csv if any.
  Result<void> loadDepthDataset() {
    const std::string& dir = options.depthDataset;
    auto cam = config::loadDepthCameraFile((std::filesystem::path(dir) / "camera.yaml").string());
    if (!cam) return fail(Status::BadArgument, "camera emulator: " + cam.error().message);
    const DepthIntrinsics k = cam->intrinsics();
    if (std::abs(k.fx - k.fy) > 1e-9 * k.fx)
      return fail(Status::BadArgument, fmt::format("camera emulator: {}/camera.yaml: fx {} and fy {} differ, but a GenICam "
                                                   "depth camera has one Scan3dFocalLength",
                                                   dir, k.fx, k.fy));
    auto names = config::listDepthImages(dir);
    if (!names) return fail(Status::BadArgument, "camera emulator: " + names.error().message);
    for (const auto& n : *names) {
      const std::string path = (std::filesystem::path(dir) / n).string();
      cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
      if (img.type() != CV_16UC1)
        return fail(Status::BadArgument, "camera emulator: " + path + ": not a 16-bit single-channel depth image");
      if (img.cols != cam->width || img.rows != cam->height)
        return fail(Status::BadArgument, fmt::format("camera emulator: {}: {}x{} px, camera.yaml says {}x{}", path, img.cols,
                                                     img.rows, cam->width, cam->height));
      depthImages.push_back(img);
      depthNames.push_back(n);
    }
    const std::string truthPath = (std::filesystem::path(dir) / "truth.csv").string();
    if (std::filesystem::exists(truthPath)) {
      auto rows = config::loadDepthTruth(truthPath);
      if (!rows) return fail(Status::BadArgument, "camera emulator: " + rows.error().message);
      for (const auto& r : *rows) {
        auto& parts = depthTruth[r.image];
        if (r.hasPart) parts.push_back(r.pose);
      }
    }
    depthCamera = *cam;
    depthMode = true;
    return {};
  }

  // The extended GenICam XML, written where arv_gv_fake_camera_new_full reads it.
  Result<std::string> writeDepthXml() {
    ArvFakeCamera* stock = arv_fake_camera_new(options.serial.c_str());
    size_t size = 0;
    const char* text = stock ? arv_fake_camera_get_genicam_xml(stock, &size) : nullptr;
    std::string xml = text ? std::string(text, size) : std::string();
    if (stock) g_object_unref(stock);
    auto patched = depthCameraXml(xml);
    if (!patched) return std::unexpected(patched.error());
    const std::string path = (std::filesystem::temp_directory_path() /
                              fmt::format("vgr-sim-depth-{}-{}.xml", ::getpid(), options.serial))
                                 .string();
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (!f || std::fwrite(patched->data(), 1, patched->size(), f) != patched->size()) {
      if (f) std::fclose(f);
      return fail(Status::Internal, "camera emulator: cannot write " + path);
    }
    std::fclose(f);
    return path;
  }

  void writeU32(std::uint32_t address, std::uint32_t value) {
    const guint32 be = GUINT32_TO_BE(value);
    arv_fake_camera_write_memory(arv_gv_fake_camera_get_fake_camera(camera), address, 4, &be);
  }
  void writeF64(std::uint32_t address, double value) {
    guint64 bits = 0;
    std::memcpy(&bits, &value, 8);
    bits = GUINT64_TO_BE(bits);
    arv_fake_camera_write_memory(arv_gv_fake_camera_get_fake_camera(camera), address, 8, &bits);
  }

  // Aravis' fake camera thread, once per frame, with the fake camera's fill-pattern mutex held.
  static void fill(ArvBuffer* buffer, void* data, guint32 /*exposureUs*/, guint32 /*gain*/, ArvPixelFormat format) {
    auto* self = static_cast<Impl*>(data);
    // Aravis 0.8.26 reports the *received* size here (0 for a buffer being filled); the
    // buffer itself was allocated by the fake camera with the full payload, which it sends.
    auto* out = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    const std::uint64_t frameId = arv_buffer_get_frame_id(buffer);
    gint x = 0, y = 0, w = 0, h = 0;
    arv_buffer_get_image_region(buffer, &x, &y, &w, &h);
    if (self->depthMode) {
      if (out == nullptr || x < 0 || y < 0 || w <= 0 || h <= 0 || x + w > self->width || y + h > self->height) {
        log::warn("sim", "fill: region {}x{}+{}+{} outside the depth sensor", w, h, x, y);
        return;
      }
      self->fillDepth(out, frameId, x, y, w, h, format);
      return;
    }
    const bool mono16 = format == ARV_PIXEL_FORMAT_MONO_16;
    const bool eightBit = format == ARV_PIXEL_FORMAT_MONO_8 || format == ARV_PIXEL_FORMAT_BAYER_RG_8 ||
                          format == ARV_PIXEL_FORMAT_BAYER_GR_8 || format == ARV_PIXEL_FORMAT_BAYER_GB_8 ||
                          format == ARV_PIXEL_FORMAT_BAYER_BG_8;
    if ((!mono16 && !eightBit) || out == nullptr || x < 0 || y < 0 || w <= 0 || h <= 0 || x + w > self->width ||
        y + h > self->height) {
      log::warn("sim", "fill: unsupported pixel format 0x{:x} or region {}x{}+{}+{}", static_cast<unsigned>(format), w, h, x, y);
      return;
    }
    std::vector<CellPartTruth> t;
    bool hasTruth = false;
    // A gray scene is its own Bayer mosaic (R = G = B), so Bayer8 serves the Mono8 bytes.
    const cv::Mat& src = self->source(frameId, mono16 ? CV_16U : CV_8U, t, hasTruth);
    const size_t row = static_cast<size_t>(w) * (mono16 ? 2 : 1);
    for (int r = 0; r < h; ++r) std::memcpy(out + r * row, src.ptr(y + r) + static_cast<size_t>(x) * src.elemSize(), row);
    self->served++;
    if (self->truth && hasTruth) {
      std::fprintf(self->truth, "%s\n", CellScenes::truthJson(frameId, t).c_str());
      std::fflush(self->truth);
    }
  }

  Result<void> loadImages() {
    namespace fs = std::filesystem;
    std::error_code ec;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(options.imagesFolder, ec))
      if (e.is_regular_file()) files.push_back(e.path());
    if (ec) return fail(Status::BadArgument, "camera emulator: cannot list " + options.imagesFolder + ": " + ec.message());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      cv::Mat img = cv::imread(f.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
      if (img.empty()) continue;  // not an image
      if (img.depth() != CV_8U && img.depth() != CV_16U)
        return fail(Status::BadArgument, "camera emulator: " + f.string() + ": only 8- and 16-bit images are served");
      if (!images.empty() && img.size() != images.front().size())
        return fail(Status::BadArgument, "camera emulator: " + f.string() + " is " + std::to_string(img.cols) + "x" +
                                             std::to_string(img.rows) + ", the folder's first image is " +
                                             std::to_string(images.front().cols) + "x" + std::to_string(images.front().rows));
      images.push_back(img);
    }
    if (images.empty()) return fail(Status::BadArgument, "camera emulator: no readable images in " + options.imagesFolder);
    return {};
  }
};

CameraEmulator::CameraEmulator(CellScenes scenes, EmulatorOptions options)
    : impl_(std::make_unique<Impl>(std::move(scenes), std::move(options))) {}

CameraEmulator::~CameraEmulator() {
  if (impl_->camera) g_object_unref(impl_->camera);
  if (impl_->truth) std::fclose(impl_->truth);
}

std::uint64_t CameraEmulator::framesServed() const { return impl_->served.load(); }

bool CameraEmulator::pulseLine() {
  if (!impl_->camera) return false;
  std::lock_guard lock(impl_->lineMutex);
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(impl_->camera);
  guint32 mode = 0, source = 0;
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_MODE, &mode);
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE, &source);
  if (mode != 1 || source != 0) return false;  // not armed for Line0
  // The fake camera only fires on its software-trigger register: route the edge through it
  // for the moment the camera thread needs to see it (it polls at 1 kHz), then restore Line0.
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE, 1);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 1);
  for (int i = 0; i < 200; ++i) {
    guint32 pending = 1;
    arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, &pending);
    if (pending == 0) break;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE, 0);
  return true;
}

void CameraEmulator::setLossRatio(double ratio) {
  if (!impl_->camera || !(ratio >= 0.0 && ratio <= 1.0)) return;
  // Aravis' fake camera thread reads the ratio for every packet it sends.
  g_object_set(impl_->camera, "gvsp-lost-ratio", ratio, nullptr);
  log::info("sim", "camera emulator {}: packet loss now {}", impl_->options.serial, ratio);
}

Result<void> CameraEmulator::start() {
  const auto& o = impl_->options;
  if (!(o.lossRatio >= 0.0 && o.lossRatio <= 1.0))
    return fail(Status::BadArgument, "camera emulator: the packet loss ratio must be in [0, 1]");
  if (!(o.fps > 0.0 && o.fps <= 1000.0)) return fail(Status::BadArgument, "camera emulator: fps must be in (0, 1000]");
  // Aravis' fake camera reports "running" even when its GVCP socket failed to bind
  // (PITFALLS.md): probe the port ourselves first.
  {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(3956);
    if (::inet_pton(AF_INET, o.address.c_str(), &sa.sin_addr) != 1) {
      ::close(fd);
      return fail(Status::BadArgument, "camera emulator: '" + o.address + "' is not an IPv4 address");
    }
    const int rc = ::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
    const int err = errno;
    ::close(fd);
    if (rc != 0 && err == EADDRNOTAVAIL)
      return fail(Status::CameraError, "camera emulator: " + o.address + " is not an address of this host (add it with "
                                       "`ip addr add " + o.address + "/8 dev lo`)");
    if (rc != 0)
      return fail(Status::CameraError, "camera emulator: cannot bind GVCP port " + o.address + ":3956 (" +
                                           std::strerror(err) + "): another camera is serving there?");
  }
  if (!o.depthDataset.empty()) {
    if (!o.imagesFolder.empty()) return fail(Status::BadArgument, "camera emulator: a depth data set or an image folder, not both");
    if (o.depthUnit != "Millimeter" && o.depthUnit != "Inch" && o.depthUnit != "Pixel")
      return fail(Status::BadArgument, "camera emulator: depth unit '" + o.depthUnit + "': expected Millimeter, Inch or Pixel");
    if (auto r = impl_->loadDepthDataset(); !r) return r;
    impl_->width = impl_->depthCamera.width;
    impl_->height = impl_->depthCamera.height;
  } else if (!o.imagesFolder.empty()) {
    if (auto r = impl_->loadImages(); !r) return r;
    impl_->width = impl_->images.front().cols;
    impl_->height = impl_->images.front().rows;
  } else {
    impl_->width = impl_->scenes.width();
    impl_->height = impl_->scenes.height();
  }
  if (!o.truthPath.empty()) {
    impl_->truth = std::fopen(o.truthPath.c_str(), "a");
    if (!impl_->truth) return fail(Status::BadArgument, "camera emulator: cannot open truth file " + o.truthPath);
  }

  if (impl_->depthMode) {
    auto xml = impl_->writeDepthXml();
    if (!xml) return std::unexpected(xml.error());
    impl_->camera = arv_gv_fake_camera_new_full(o.address.c_str(), o.serial.c_str(), xml->c_str());
    std::error_code ec;
    std::filesystem::remove(*xml, ec);  // read at construction
  } else {
    impl_->camera = arv_gv_fake_camera_new(o.address.c_str(), o.serial.c_str());
  }
  if (!impl_->camera || !arv_gv_fake_camera_is_running(impl_->camera))
    return fail(Status::CameraError, "camera emulator: Aravis could not start a fake GigE camera on " + o.address);
  // Aravis 0.8.26's fake GigE camera drops each GVSP packet with this probability.
  g_object_set(impl_->camera, "gvsp-lost-ratio", o.lossRatio, nullptr);
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(impl_->camera);
  // The stock fake camera polls for software triggers at 25 Hz (40 ms latency): 1 kHz instead.
  arv_fake_camera_set_trigger_frequency(fake, 1000.0);
  const auto w = static_cast<guint32>(impl_->width);
  const auto h = static_cast<guint32>(impl_->height);
  // The sensor is the image: ROI width 0 ("rest of the sensor") is the whole scene.
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, w);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, h);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_WIDTH, w);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_HEIGHT, h);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US,
                                 static_cast<guint32>(1e6 / o.fps));
  if (impl_->depthMode) {
    // A depth camera from the start: Coord3D_C16 and its Scan3d features (depth_xml.hpp).
    const auto& c = impl_->depthCamera;
    const double perUnit = o.depthUnit == "Inch" ? c.depthScaleMm / 25.4 : c.depthScaleMm;
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_PIXEL_FORMAT, kPixelFormatCoord3dC16);
    impl_->writeU32(kScan3dDistanceUnit, o.depthUnit == "Millimeter" ? 0 : o.depthUnit == "Inch" ? 1 : 2);
    impl_->writeU32(kScan3dCoordinateSelector, 2);
    impl_->writeU32(kScan3dCoordinateSystem, 0);
    impl_->writeU32(kScan3dOutputMode, 0);
    impl_->writeU32(kScan3dInvalidDataFlag, 1);
    impl_->writeF64(kScan3dCoordinateScale, perUnit);
    impl_->writeF64(kScan3dCoordinateOffset, 0.0);
    impl_->writeF64(kScan3dInvalidDataValue, 0.0);
    impl_->writeF64(kScan3dFocalLength, c.fx);
    impl_->writeF64(kScan3dPrincipalPointU, c.cx);
    impl_->writeF64(kScan3dPrincipalPointV, c.cy);
  }
  arv_fake_camera_set_fill_pattern(fake, &Impl::fill, impl_.get());
  const std::string what = impl_->depthMode ? fmt::format("Coord3D_C16 depth images of {} ({} images, {} mm/unit, {})",
                                                     o.depthDataset, impl_->depthImages.size(),
                                                     impl_->depthCamera.depthScaleMm, o.depthUnit)
                           : o.imagesFolder.empty() ? "rendered '" + impl_->scenes.mode() + "' scenes"
                                                    : "images of " + o.imagesFolder;
  log::info("sim", "camera emulator {} serving {}x{} {} on {} (packet loss {}, free-run {} fps)", o.serial, w, h, what,
            o.address, o.lossRatio, o.fps);
  return {};
}

}  // namespace vgr::sim
