#include "drivers/aravis_camera.hpp"

#include <atomic>
#include <chrono>
#include <cstring>

#include <arv.h>

#include "core/log.hpp"

namespace vgr::drivers {
namespace {

std::string takeMessage(GError*& e) {
  std::string m = e ? e->message : "unknown error";
  g_clear_error(&e);
  return m;
}

std::uint64_t nowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

constexpr int kBufferCount = 4;  // preallocated, recycled; the stream never allocates per frame

class AravisCamera final : public Camera {
 public:
  explicit AravisCamera(config::CameraConfig c) : cfg_(std::move(c)) {}
  ~AravisCamera() override { close(); }

  std::string describe() const override {
    std::string d = "camera '" + cfg_.name + "' (aravis " + (cfg_.address.empty() ? cfg_.serial : cfg_.address);
    if (!cfg_.serial.empty() && !cfg_.address.empty()) d += ", serial " + cfg_.serial;
    return d + ")";
  }

  CameraState state() const override { return state_; }
  FrameStatus lastFrameStatus() const override { return lastStatus_; }
  bool controlLost() const override { return controlLost_.load(); }

  Result<void> open() override {
    if (state_ != CameraState::Closed) return fail(Status::Internal, describe() + ": open() while not closed");
    GError* err = nullptr;
    // By IP when given: discovery by name uses a packet socket that sees nothing on loopback.
    const std::string id = cfg_.address.empty() ? cfg_.serial : cfg_.address;
    camera_ = arv_camera_new(id.c_str(), &err);
    if (!camera_) return fail(Status::CameraError, describe() + ": cannot open: " + takeMessage(err));
    if (arv_camera_is_gv_device(camera_)) {
      arv_camera_gv_set_stream_options(camera_, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
      // Bigger packets: fewer of them to lose, ~3x lower latency than the 1400-byte default
      // on loopback (PITFALLS.md). 0 = let Aravis negotiate (needs GevSCPSFireTestPacket,
      // which the emulator lacks: its config sets the size).
      if (cfg_.packetSize > 0)
        arv_camera_gv_set_packet_size(camera_, cfg_.packetSize, &err);
      else
        arv_camera_gv_auto_packet_size(camera_, &err);
      if (err) {
        log::warn("camera", "{}: setting the packet size failed: {}", describe(), takeMessage(err));
      }
    }
    controlLost_ = false;
    ArvDevice* dev = arv_camera_get_device(camera_);
    g_signal_connect(dev, "control-lost", G_CALLBACK(&AravisCamera::onControlLost), this);

    if (!cfg_.serial.empty()) {
      const char* serial = arv_camera_get_device_serial_number(camera_, &err);
      if (err) g_clear_error(&err);
      if (serial && cfg_.serial != serial) {
        const std::string got = serial;
        close();
        return fail(Status::CameraError, describe() + ": found serial '" + got + "' at that address, expected '" + cfg_.serial + "'");
      }
    }

    auto check = [&](const char* what) -> Result<void> {
      if (!err) return {};
      std::string m = describe() + ": cannot set " + what + ": " + takeMessage(err);
      close();
      return fail(Status::CameraError, m);
    };
    arv_camera_set_pixel_format(camera_, ARV_PIXEL_FORMAT_MONO_8, &err);
    if (auto r = check("PixelFormat=Mono8"); !r) return r;
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &err);
    if (auto r = check("AcquisitionMode=Continuous"); !r) return r;
    arv_camera_set_exposure_time(camera_, cfg_.exposureUs, &err);
    if (auto r = check("ExposureTime"); !r) return r;
    arv_camera_set_trigger(camera_, "Software", &err);
    if (auto r = check("TriggerSource=Software"); !r) return r;
    gint x = 0, y = 0;
    arv_camera_get_region(camera_, &x, &y, &width_, &height_, &err);
    if (auto r = check("(reading Width/Height)"); !r) return r;
    state_ = CameraState::Open;
    return {};
  }

  void close() override {
    if (state_ == CameraState::Streaming) stop();
    if (camera_) {
      g_signal_handlers_disconnect_by_data(arv_camera_get_device(camera_), this);
      g_clear_object(&camera_);
    }
    state_ = CameraState::Closed;
  }

  Result<void> start() override {
    if (state_ != CameraState::Open) return fail(Status::Internal, describe() + ": start() while not open");
    GError* err = nullptr;
    const guint payload = arv_camera_get_payload(camera_, &err);
    if (err) return fail(Status::CameraError, describe() + ": cannot read the payload size: " + takeMessage(err));
    stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &err);
    if (!stream_) return fail(Status::CameraError, describe() + ": cannot create the stream: " + takeMessage(err));
    if (ARV_IS_GV_STREAM(stream_)) {
      // A whole frame fits the UDP receive buffer (bounded by net.core.rmem_max): without
      // it, bursts overflow the kernel buffer and a camera without resend loses the frame.
      g_object_set(stream_, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_AUTO, nullptr);
    }
    for (int i = 0; i < kBufferCount; ++i) arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
    arv_camera_start_acquisition(camera_, &err);
    if (err) {
      std::string m = takeMessage(err);
      g_clear_object(&stream_);
      return fail(Status::CameraError, describe() + ": cannot start acquisition: " + m);
    }
    state_ = CameraState::Streaming;
    // Aravis 0.8 sizes the UDP receive buffer to the payload only when the first frame
    // begins, so the first frame after stream creation overflows the default buffer and
    // is lost. Spend it now, at connect time, instead of on the first real trigger.
    Frame primer;
    if (auto r = triggerAndWait(primer, std::chrono::milliseconds(cfg_.timeoutMs)); !r)
      log::debug("camera", "{}: priming frame: {}", describe(), r.error().message);
    return {};
  }

  void stop() override {
    if (state_ != CameraState::Streaming) return;
    GError* err = nullptr;
    arv_camera_stop_acquisition(camera_, &err);  // blocks ~2.5 s on a dead camera
    if (err) {
      log::debug("camera", "{}: stop acquisition: {}", describe(), takeMessage(err));
    }
    g_clear_object(&stream_);
    state_ = CameraState::Open;
  }

  Result<void> triggerAndWait(Frame& out, std::chrono::milliseconds timeout) override {
    if (state_ != CameraState::Streaming) {
      lastStatus_ = FrameStatus::Failed;
      return fail(Status::Internal, describe() + ": trigger while not streaming");
    }
    if (controlLost_) {
      lastStatus_ = FrameStatus::Disconnected;
      return fail(Status::CameraError, describe() + ": control channel lost");
    }
    // Recycle frames that arrived late for an earlier trigger: they are not this trigger's.
    while (ArvBuffer* stale = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, stale);

    GError* err = nullptr;
    arv_camera_software_trigger(camera_, &err);
    if (err) {
      lastStatus_ = FrameStatus::Disconnected;
      return fail(Status::CameraError, describe() + ": software trigger failed: " + takeMessage(err));
    }
    ArvBuffer* buf = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(timeout.count()) * 1000);
    if (!buf) {
      lastStatus_ = FrameStatus::Timeout;
      return fail(Status::CameraError, describe() + ": no frame within " + std::to_string(timeout.count()) + " ms");
    }
    const ArvBufferStatus st = arv_buffer_get_status(buf);
    if (st != ARV_BUFFER_STATUS_SUCCESS) {
      lastStatus_ = st == ARV_BUFFER_STATUS_TIMEOUT ? FrameStatus::Timeout : FrameStatus::Incomplete;
      arv_stream_push_buffer(stream_, buf);
      return fail(Status::CameraError, describe() + ": frame incomplete (buffer status " + std::to_string(st) + ")");
    }
    size_t size = 0;
    const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buf, &size));
    const int w = arv_buffer_get_image_width(buf), h = arv_buffer_get_image_height(buf);
    if (arv_buffer_get_image_pixel_format(buf) != ARV_PIXEL_FORMAT_MONO_8 || size < static_cast<size_t>(w) * h) {
      arv_stream_push_buffer(stream_, buf);
      lastStatus_ = FrameStatus::Failed;
      return fail(Status::CameraError, describe() + ": unexpected pixel format or size");
    }
    out.data.resize(static_cast<size_t>(w) * h);  // no reallocation once warmed up
    std::memcpy(out.data.data(), data, out.data.size());
    out.width = w;
    out.height = h;
    out.frameId = arv_buffer_get_frame_id(buf);
    out.deviceTimestampNs = arv_buffer_get_timestamp(buf);
    out.hostTimestampNs = nowNs();
    arv_stream_push_buffer(stream_, buf);
    lastStatus_ = FrameStatus::Ok;
    return {};
  }

 private:
  // Aravis' heartbeat thread: only sets a flag.
  static void onControlLost(ArvDevice*, gpointer self) { static_cast<AravisCamera*>(self)->controlLost_ = true; }

  config::CameraConfig cfg_;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  CameraState state_ = CameraState::Closed;
  FrameStatus lastStatus_ = FrameStatus::Ok;
  std::atomic<bool> controlLost_{false};
  gint width_ = 0, height_ = 0;
};

}  // namespace

std::unique_ptr<Camera> makeAravisCamera(const config::CameraConfig& config) {
  return std::make_unique<AravisCamera>(config);
}

}  // namespace vgr::drivers
