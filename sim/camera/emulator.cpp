#include "sim/camera/emulator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <mutex>

#include <arv.h>
#include <opencv2/core.hpp>

#include "core/log.hpp"

namespace vgr::sim {

struct CameraEmulator::Impl {
  SceneRenderer renderer;
  EmulatorOptions options;
  ArvGvFakeCamera* camera = nullptr;
  cv::Mat frame;  // reused render target
  std::atomic<std::uint64_t> served{0};
  std::FILE* truth = nullptr;

  Impl(SceneRenderer r, EmulatorOptions o) : renderer(std::move(r)), options(std::move(o)) {}

  // Aravis' fake camera thread, once per frame, with the fake camera's fill-pattern mutex held.
  static void fill(ArvBuffer* buffer, void* data, guint32 /*exposureUs*/, guint32 /*gain*/, ArvPixelFormat format) {
    auto* self = static_cast<Impl*>(data);
    // Aravis 0.8.26 reports the *received* size here (0 for a buffer being filled); the
    // buffer itself was allocated by the fake camera with the full payload (width x height
    // for Mono8), and the payload is what it sends.
    auto* out = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    const std::uint64_t frameId = arv_buffer_get_frame_id(buffer);
    const int w = self->renderer.options().width, h = self->renderer.options().height;
    if (format != ARV_PIXEL_FORMAT_MONO_8 || out == nullptr || arv_buffer_get_image_width(buffer) != w ||
        arv_buffer_get_image_height(buffer) != h) {
      log::warn("sim", "fill: unsupported pixel format 0x{:x} or image size {}x{}", static_cast<unsigned>(format),
                arv_buffer_get_image_width(buffer), arv_buffer_get_image_height(buffer));
      return;
    }
    const SceneTruth t = self->renderer.render(frameId, self->frame);
    for (int y = 0; y < h; ++y) std::memcpy(out + static_cast<size_t>(y) * w, self->frame.ptr(y), w);
    self->served++;
    if (self->truth) {
      std::fprintf(self->truth,
                   "{\"frame_id\":%llu,\"x_mm\":%.4f,\"y_mm\":%.4f,\"z_mm\":%.4f,\"rz_deg\":%.4f,"
                   "\"u_px\":%.4f,\"v_px\":%.4f,\"angle_img_deg\":%.4f}\n",
                   static_cast<unsigned long long>(frameId), t.xMm, t.yMm, t.zMm, t.rzDeg, t.uPx, t.vPx, t.angleImgDeg);
      std::fflush(self->truth);
    }
  }
};

CameraEmulator::CameraEmulator(SceneRenderer renderer, EmulatorOptions options)
    : impl_(std::make_unique<Impl>(std::move(renderer), std::move(options))) {}

CameraEmulator::~CameraEmulator() {
  if (impl_->camera) g_object_unref(impl_->camera);
  if (impl_->truth) std::fclose(impl_->truth);
}

std::uint64_t CameraEmulator::framesServed() const { return impl_->served.load(); }

Result<void> CameraEmulator::start() {
  // Aravis' fake camera reports "running" even when its GVCP socket failed to bind
  // (PITFALLS.md): probe the port ourselves first.
  {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(3956);
    if (::inet_pton(AF_INET, impl_->options.address.c_str(), &sa.sin_addr) != 1) {
      ::close(fd);
      return fail(Status::BadArgument, "camera emulator: '" + impl_->options.address + "' is not an IPv4 address");
    }
    const int rc = ::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
    const int err = errno;
    ::close(fd);
    if (rc != 0)
      return fail(Status::CameraError, "camera emulator: cannot bind GVCP port " + impl_->options.address +
                                           ":3956 (" + std::strerror(err) + "): another camera is serving there?");
  }
  if (!impl_->options.truthPath.empty()) {
    impl_->truth = std::fopen(impl_->options.truthPath.c_str(), "a");
    if (!impl_->truth) return fail(Status::BadArgument, "camera emulator: cannot open truth file " + impl_->options.truthPath);
  }

  impl_->camera = arv_gv_fake_camera_new(impl_->options.address.c_str(), impl_->options.serial.c_str());
  if (!impl_->camera || !arv_gv_fake_camera_is_running(impl_->camera))
    return fail(Status::CameraError, "camera emulator: Aravis could not start a fake GigE camera on " + impl_->options.address);
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(impl_->camera);
  // The stock fake camera polls for software triggers at 25 Hz (40 ms latency): 1 kHz instead.
  arv_fake_camera_set_trigger_frequency(fake, 1000.0);
  const auto w = static_cast<guint32>(impl_->renderer.options().width);
  const auto h = static_cast<guint32>(impl_->renderer.options().height);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, std::max<guint32>(w, 2048));
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, std::max<guint32>(h, 2048));
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_WIDTH, w);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_HEIGHT, h);
  arv_fake_camera_set_fill_pattern(fake, &Impl::fill, impl_.get());
  log::info("sim", "camera emulator {} serving {}x{} Mono8 on {}", impl_->options.serial, w, h, impl_->options.address);
  return {};
}

}  // namespace vgr::sim
