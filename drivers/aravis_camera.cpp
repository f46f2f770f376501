#include "drivers/aravis_camera.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include <arv.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/log.hpp"
#include "drivers/depth_frame.hpp"

namespace vgr::drivers {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

std::string takeMessage(GError*& e) {
  std::string m = e ? e->message : "unknown error";
  g_clear_error(&e);
  return m;
}

std::uint64_t wallNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

std::string fmtNum(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// Config pixel formats: what the camera sends and what the Frame carries.
struct FormatInfo {
  const char* name;       // GenICam PixelFormat entry
  ArvPixelFormat arv;
  PixelType out;
  int bits;
  int bayerToGray;        // OpenCV conversion code, -1 for mono
};
// OpenCV names Bayer patterns by the second row's pixels: GenICam BayerRG = OpenCV BayerBG.
const FormatInfo kFormats[] = {
    {"Mono8", ARV_PIXEL_FORMAT_MONO_8, PixelType::Mono8, 8, -1},
    {"Mono10", ARV_PIXEL_FORMAT_MONO_10, PixelType::Mono16, 10, -1},
    {"Mono12", ARV_PIXEL_FORMAT_MONO_12, PixelType::Mono16, 12, -1},
    {"Mono16", ARV_PIXEL_FORMAT_MONO_16, PixelType::Mono16, 16, -1},
    {"BayerRG8", ARV_PIXEL_FORMAT_BAYER_RG_8, PixelType::Mono8, 8, cv::COLOR_BayerBG2GRAY},
    {"BayerGR8", ARV_PIXEL_FORMAT_BAYER_GR_8, PixelType::Mono8, 8, cv::COLOR_BayerGB2GRAY},
    {"BayerGB8", ARV_PIXEL_FORMAT_BAYER_GB_8, PixelType::Mono8, 8, cv::COLOR_BayerGR2GRAY},
    {"BayerBG8", ARV_PIXEL_FORMAT_BAYER_BG_8, PixelType::Mono8, 8, cv::COLOR_BayerRG2GRAY},
    // Depth cameras: range in Scan3d units, delivered as float32 z in mm (depth_frame.hpp).
    {"Coord3D_C16", ARV_PIXEL_FORMAT_COORD3D_C_16, PixelType::DepthMm, 16, -1},
};

const FormatInfo* findFormat(const std::string& name) {
  for (const auto& f : kFormats)
    if (name == f.name) return &f;
  return nullptr;
}

std::string joinList(const char** items, guint n) {
  std::string s;
  for (guint i = 0; i < n; ++i) s += (i ? ", " : "") + std::string(items[i] ? items[i] : "?");
  return s.empty() ? "none" : s;
}

bool listContains(const char** items, guint n, const std::string& v) {
  for (guint i = 0; i < n; ++i)
    if (items[i] && v == items[i]) return true;
  return false;
}

class AravisCamera final : public Camera {
 public:
  explicit AravisCamera(config::CameraConfig c) : cfg_(std::move(c)), format_(findFormat(cfg_.pixelFormat)) {}
  ~AravisCamera() override { close(); }

  std::string describe() const override {
    std::string where = !cfg_.address.empty() ? cfg_.address : !cfg_.serial.empty() ? "serial " + cfg_.serial : "user name " + cfg_.userName;
    std::string d = "camera '" + cfg_.name + "' (aravis " + where;
    if (!cfg_.serial.empty() && !cfg_.address.empty()) d += ", serial " + cfg_.serial;
    return d + ")";
  }

  CameraState state() const override { return state_; }
  FrameStatus lastFrameStatus() const override { return lastStatus_; }
  bool controlLost() const override { return controlLost_.load(); }

  CameraStats stats() const override {
    CameraStats s = stats_;
    s.underruns += streamBase_.underruns;
    s.missingPackets += streamBase_.missingPackets;
    s.resentPackets += streamBase_.resentPackets;
    const CameraStats live = streamStats();
    s.underruns += live.underruns;
    s.missingPackets += live.missingPackets;
    s.resentPackets += live.resentPackets;
    return s;
  }

  Result<void> open() override {
    if (state_ != CameraState::Closed) return fail(Status::Internal, describe() + ": open() while not closed");
    if (!format_) return fail(Status::BadArgument, describe() + ": camera.pixel_format '" + cfg_.pixelFormat + "' is not supported by the driver");
    GError* err = nullptr;
    auto id = resolve();
    if (!id) return std::unexpected(id.error());
    camera_ = arv_camera_new(id->c_str(), &err);
    if (!camera_) return fail(Status::CameraError, describe() + ": cannot open: " + takeMessage(err));
    controlLost_ = false;
    deviceGone_ = false;
    if (arv_camera_is_gv_device(camera_)) {
      // Without this, Aravis (as root) receives the stream on a packet socket bound to the
      // real interface and sees nothing on loopback (PITFALLS.md).
      arv_camera_gv_set_stream_options(camera_, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
    }
    g_signal_connect(arv_camera_get_device(camera_), "control-lost", G_CALLBACK(&AravisCamera::onControlLost), this);

    if (!cfg_.serial.empty()) {
      const char* serial = arv_camera_get_device_serial_number(camera_, &err);
      if (err) g_clear_error(&err);
      if (serial && cfg_.serial != serial) {
        const std::string got = serial;
        close();
        return fail(Status::CameraError, describe() + ": camera.serial: found serial '" + got + "' at that address, expected '" + cfg_.serial + "'");
      }
    }
    if (auto r = applyFeatures(); !r) {
      close();
      return r;
    }
    state_ = CameraState::Open;
    return {};
  }

  void close() override {
    const bool gone = camera_ && (deviceGone_ || controlLost_ || !reachable());
    if (state_ == CameraState::Streaming) stop(gone);
    if (camera_) {
      g_signal_handlers_disconnect_by_data(arv_camera_get_device(camera_), this);
      if (gone) {
        // Destroying a stream or device sends GVCP commands (stream channel reset, control
        // release) that block ~2.5 s each on a dead camera (measured: 10 s per close).
        // Let a short-lived thread pay for that so that reconnecting can start at once;
        // a camera that came back ignores the old session's writes (they are not from its
        // controller, GigE Vision CCP), so the late commands cannot disturb the new one.
        std::thread([camera = camera_] { g_object_unref(camera); }).detach();
        camera_ = nullptr;
      } else {
        g_clear_object(&camera_);
      }
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
      if (cfg_.socketBufferBytes > 0)
        g_object_set(stream_, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                     cfg_.socketBufferBytes, nullptr);
      else
        g_object_set(stream_, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_AUTO, nullptr);
      g_object_set(stream_, "packet-resend",
                   cfg_.packetResend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER, nullptr);
    }
    // The buffer pool: allocated once per stream, recycled; nothing allocates per frame.
    for (int i = 0; i < cfg_.bufferCount; ++i) arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
    arv_camera_start_acquisition(camera_, &err);
    if (err) {
      std::string m = takeMessage(err);
      g_clear_object(&stream_);
      return fail(Status::CameraError, describe() + ": cannot start acquisition: " + m);
    }
    state_ = CameraState::Streaming;
    // Aravis 0.8 sizes the UDP receive buffer to the payload only when the first frame
    // begins, so the first frame after stream creation is lost in a burst. With a software
    // trigger, spend it now, at connect time, instead of on the first real trigger.
    if (cfg_.trigger == config::TriggerMode::Software) {
      Frame primer;
      if (auto r = acquire(primer, milliseconds(cfg_.timeoutMs)); !r)
        log::debug("camera", "{}: priming frame: {}", describe(), r.error().message);
    }
    return {};
  }

  void stop() override { stop(deviceGone_ || controlLost_ || !reachable()); }

 private:
  // `gone`: the camera does not answer, so send it nothing (every GVCP command to a dead
  // camera blocks ~2.5 s) and dispose of the stream off-thread.
  void stop(bool gone) {
    if (state_ != CameraState::Streaming) return;
    if (!gone) {
      GError* err = nullptr;
      arv_camera_stop_acquisition(camera_, &err);
      if (err) log::debug("camera", "{}: stop acquisition: {}", describe(), takeMessage(err));
    }
    const CameraStats live = streamStats();
    streamBase_.underruns += live.underruns;
    streamBase_.missingPackets += live.missingPackets;
    streamBase_.resentPackets += live.resentPackets;
    if (gone)  // see close(): the stream's destruction blocks ~2.5 s on a dead camera
      std::thread([stream = stream_] { g_object_unref(stream); }).detach();
    else
      g_object_unref(stream_);  // frees the pool
    stream_ = nullptr;
    state_ = CameraState::Open;
  }

 public:
  Result<void> triggerAndWait(Frame& out, milliseconds timeout) override {
    auto r = acquire(out, timeout);
    if (r) {
      stats_.completed++;
    } else if (lastStatus_ != FrameStatus::IllegalState) {
      stats_.failed++;
      if (lastStatus_ == FrameStatus::Timeout) stats_.timeouts++;
      if (lastStatus_ == FrameStatus::Incomplete) stats_.incomplete++;
    }
    return r;
  }

 private:
  // Aravis' heartbeat thread: only sets a flag.
  static void onControlLost(ArvDevice*, gpointer self) { static_cast<AravisCamera*>(self)->controlLost_ = true; }

  Result<void> failSetting(const std::string& key, const std::string& what) {
    return fail(Status::CameraError, describe() + ": camera." + key + ": " + what);
  }

  // The Aravis device id to open: the IP address (checked with one GVCP probe first, so a
  // missing camera fails in 300 ms instead of blocking), the address discovery found for
  // the serial, or the user name (Aravis matches DeviceUserID itself).
  Result<std::string> resolve() {
    if (!cfg_.address.empty()) {
      if (!probeGigECamera(cfg_.address, milliseconds(300)))
        return fail(Status::CameraError, describe() + ": cannot open: no GigE Vision camera answers at " + cfg_.address + ":3956");
      address_ = cfg_.address;
      return cfg_.address;
    }
    if (!cfg_.serial.empty()) {
      // Reconnects try the last known address first: discovery costs ~1 s.
      if (!address_.empty() && probeGigECamera(address_, milliseconds(300))) return address_;
      std::string found;
      for (const auto& d : discoverCameras()) {
        if (d.serial == cfg_.serial || d.id == cfg_.serial) {
          address_ = d.address;
          return d.address.empty() ? d.id : d.address;
        }
        found += (found.empty() ? "" : ", ") + d.serial + " (" + d.model + ", " + d.address + ")";
      }
      return fail(Status::CameraError, describe() + ": camera.serial: no camera with serial '" + cfg_.serial +
                                           "' on the network (found: " + (found.empty() ? "none" : found) + ")");
    }
    return cfg_.userName;
  }

  // GigE Vision bootstrap register CCP (0x0A00): bit 0/1 = exclusive/control access. Reads 0
  // after the camera restarted, because the new instance never granted us control.
  bool controlHeld(std::string& why) {
    if (!arv_camera_is_gv_device(camera_)) return true;
    GError* err = nullptr;
    guint32 v = 0;
    arv_device_read_register(arv_camera_get_device(camera_), 0x0A00, &v, &err);
    if (err) {
      deviceGone_ = true;
      why = "the camera does not answer: " + takeMessage(err);
      return false;
    }
    if ((v & 0x3u) == 0) {
      why = "the camera restarted (control privilege lost)";
      return false;
    }
    return true;
  }

  bool reachable() const { return address_.empty() || probeGigECamera(address_, milliseconds(100)); }

  Result<void> applyFeatures() {
    GError* err = nullptr;
    auto check = [&](const std::string& key, const std::string& what) -> Result<void> {
      if (!err) return {};
      return failSetting(key, "cannot set " + what + ": " + takeMessage(err));
    };
    const bool gv = arv_camera_is_gv_device(camera_);
    if (gv) {
      // Bigger packets: fewer of them to lose, ~3x lower latency than the 1400-byte default
      // on loopback (PITFALLS.md). 0 = let Aravis negotiate (needs GevSCPSFireTestPacket).
      if (cfg_.packetSize > 0) {
        arv_camera_gv_set_packet_size(camera_, cfg_.packetSize, &err);
        if (auto r = check("packet_size", "GevSCPSPacketSize=" + std::to_string(cfg_.packetSize)); !r) return r;
      } else {
        arv_camera_gv_auto_packet_size(camera_, &err);
        if (err) log::warn("camera", "{}: camera.packet_size: negotiation failed, keeping the camera's size: {}", describe(), takeMessage(err));
      }
      if (cfg_.packetDelayNs > 0) {
        arv_camera_gv_set_packet_delay(camera_, cfg_.packetDelayNs, &err);
        if (auto r = check("packet_delay_ns", "GevSCPD"); !r) return r;
      }
    }

    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &err);
    if (auto r = check("trigger", "AcquisitionMode=Continuous"); !r) return r;

    // Pixel format: only entries the camera offers.
    guint n = 0;
    const char** formats = arv_camera_dup_available_pixel_formats_as_strings(camera_, &n, &err);
    if (err) return failSetting("pixel_format", "cannot read the camera's pixel formats: " + takeMessage(err));
    const bool offered = listContains(formats, n, format_->name);
    const std::string offer = joinList(formats, n);
    g_free(formats);
    if (!offered) {
      if (format_->out == PixelType::DepthMm)
        return failSetting("pixel_format", "the camera's PixelFormat has no 'Coord3D_C16' entry: not a depth camera the driver "
                                           "can use (it offers " + offer + ")");
      return failSetting("pixel_format", "'" + cfg_.pixelFormat + "' is not supported by the camera; it offers " + offer);
    }
    arv_camera_set_pixel_format(camera_, format_->arv, &err);
    if (auto r = check("pixel_format", "PixelFormat=" + cfg_.pixelFormat); !r) return r;
    if (format_->out == PixelType::DepthMm) {
      if (cfg_.roiX != 0 || cfg_.roiY != 0)
        return failSetting("roi", "a depth camera's Scan3dPrincipalPointU/V are taken as the camera gives them; an ROI "
                                  "offset would move the principal point, so it is not supported");
      if (auto r = applyDepthFeatures(); !r) return r;
    }

    // Region of interest: offsets to 0 first so that any width fits, then size, then offsets.
    gint sensorW = 0, sensorH = 0;
    arv_camera_get_sensor_size(camera_, &sensorW, &sensorH, &err);
    if (err) {
      g_clear_error(&err);
      gint x0, y0;
      arv_camera_get_region(camera_, &x0, &y0, &sensorW, &sensorH, &err);
      if (auto r = check("roi", "(reading the sensor size)"); !r) return r;
    }
    const int w = cfg_.roiWidth > 0 ? cfg_.roiWidth : sensorW - cfg_.roiX;
    const int h = cfg_.roiHeight > 0 ? cfg_.roiHeight : sensorH - cfg_.roiY;
    if (w <= 0 || cfg_.roiX + w > sensorW)
      return failSetting("roi", "x + width = " + std::to_string(cfg_.roiX + std::max(w, 0)) + " exceeds the sensor width " + std::to_string(sensorW));
    if (h <= 0 || cfg_.roiY + h > sensorH)
      return failSetting("roi", "y + height = " + std::to_string(cfg_.roiY + std::max(h, 0)) + " exceeds the sensor height " + std::to_string(sensorH));
    const bool offsets = arv_camera_is_region_offset_available(camera_, nullptr);
    if (offsets) {
      arv_camera_set_integer(camera_, "OffsetX", 0, &err);
      if (!err) arv_camera_set_integer(camera_, "OffsetY", 0, &err);
      if (auto r = check("roi", "OffsetX/OffsetY=0"); !r) return r;
    } else if (cfg_.roiX || cfg_.roiY) {
      return failSetting("roi", "the camera has no OffsetX/OffsetY");
    }
    arv_camera_set_integer(camera_, "Width", w, &err);
    if (auto r = check("roi.width", "Width=" + std::to_string(w)); !r) return r;
    arv_camera_set_integer(camera_, "Height", h, &err);
    if (auto r = check("roi.height", "Height=" + std::to_string(h)); !r) return r;
    if (offsets && (cfg_.roiX || cfg_.roiY)) {
      arv_camera_set_integer(camera_, "OffsetX", cfg_.roiX, &err);
      if (auto r = check("roi.x", "OffsetX=" + std::to_string(cfg_.roiX)); !r) return r;
      arv_camera_set_integer(camera_, "OffsetY", cfg_.roiY, &err);
      if (auto r = check("roi.y", "OffsetY=" + std::to_string(cfg_.roiY)); !r) return r;
    }

    // Exposure and gain: the camera's own range decides (Aravis does not range-check).
    if (arv_camera_is_exposure_time_available(camera_, nullptr)) {
      double lo = 0, hi = 0;
      arv_camera_get_exposure_time_bounds(camera_, &lo, &hi, &err);
      if (auto r = check("exposure_us", "(reading the exposure range)"); !r) return r;
      if (cfg_.exposureUs < lo || cfg_.exposureUs > hi)
        return failSetting("exposure_us", fmtNum(cfg_.exposureUs) + " is out of the camera's range [" + fmtNum(lo) + ", " + fmtNum(hi) + "] µs");
      arv_camera_set_exposure_time(camera_, cfg_.exposureUs, &err);
      if (auto r = check("exposure_us", "ExposureTime"); !r) return r;
    } else {
      log::warn("camera", "{}: the camera has no exposure time feature; camera.exposure_us ignored", describe());
    }
    if (cfg_.gain >= 0) {
      if (!arv_camera_is_gain_available(camera_, nullptr)) return failSetting("gain", "the camera has no Gain/GainRaw feature");
      double lo = 0, hi = 0;
      arv_camera_get_gain_bounds(camera_, &lo, &hi, &err);
      if (auto r = check("gain", "(reading the gain range)"); !r) return r;
      if (cfg_.gain < lo || cfg_.gain > hi)
        return failSetting("gain", fmtNum(cfg_.gain) + " is out of the camera's range [" + fmtNum(lo) + ", " + fmtNum(hi) + "]");
      arv_camera_set_gain(camera_, cfg_.gain, &err);
      if (auto r = check("gain", "Gain"); !r) return r;
    }

    // Trigger.
    switch (cfg_.trigger) {
      case config::TriggerMode::Software:
        if (!arv_camera_is_software_trigger_supported(camera_, nullptr))
          return failSetting("trigger.mode", "the camera has no software trigger");
        arv_camera_set_trigger(camera_, "Software", &err);
        if (auto r = check("trigger.mode", "TriggerSource=Software"); !r) return r;
        break;
      case config::TriggerMode::Hardware: {
        guint ns = 0;
        const char** sources = arv_camera_dup_available_trigger_sources(camera_, &ns, &err);
        if (err) return failSetting("trigger.line", "cannot read the camera's trigger sources: " + takeMessage(err));
        const bool ok = listContains(sources, ns, cfg_.triggerLine);
        const std::string list = joinList(sources, ns);
        g_free(sources);
        if (!ok) return failSetting("trigger.line", "'" + cfg_.triggerLine + "' is not a trigger source of the camera; it offers " + list);
        arv_camera_set_trigger(camera_, cfg_.triggerLine.c_str(), &err);
        if (auto r = check("trigger.line", "TriggerSource=" + cfg_.triggerLine); !r) return r;
        if (arv_camera_is_feature_available(camera_, "TriggerActivation", nullptr)) {
          if (!arv_camera_is_enumeration_entry_available(camera_, "TriggerActivation", cfg_.triggerActivation.c_str(), nullptr))
            return failSetting("trigger.activation", "'" + cfg_.triggerActivation + "' is not offered by the camera");
          arv_camera_set_string(camera_, "TriggerActivation", cfg_.triggerActivation.c_str(), &err);
          if (auto r = check("trigger.activation", "TriggerActivation=" + cfg_.triggerActivation); !r) return r;
        } else if (cfg_.triggerActivation != "RisingEdge") {
          return failSetting("trigger.activation", "the camera has no TriggerActivation feature");
        }
        if (cfg_.triggerDelayUs > 0) {
          const char* feature = arv_camera_is_feature_available(camera_, "TriggerDelay", nullptr)      ? "TriggerDelay"
                                : arv_camera_is_feature_available(camera_, "TriggerDelayAbs", nullptr) ? "TriggerDelayAbs"
                                                                                                        : nullptr;
          if (!feature) return failSetting("trigger.delay_us", "the camera has no TriggerDelay feature");
          arv_camera_set_float(camera_, feature, cfg_.triggerDelayUs, &err);
          if (auto r = check("trigger.delay_us", feature); !r) return r;
        }
        break;
      }
      case config::TriggerMode::FreeRun:
        arv_camera_clear_triggers(camera_, &err);
        if (auto r = check("trigger.mode", "TriggerMode=Off"); !r) return r;
        break;
    }

    // Read back what the camera actually runs with: logged once per (re)connect.
    gint x = 0, y = 0, rw = 0, rh = 0;
    arv_camera_get_region(camera_, &x, &y, &rw, &rh, &err);
    if (auto r = check("roi", "(reading the region back)"); !r) return r;
    width_ = rw;
    height_ = rh;
    const char* pf = arv_camera_get_pixel_format_as_string(camera_, nullptr);
    const double exp = arv_camera_get_exposure_time(camera_, nullptr);
    const double gain = arv_camera_is_gain_available(camera_, nullptr) ? arv_camera_get_gain(camera_, nullptr) : 0.0;
    const char* src = arv_camera_get_trigger_source(camera_, nullptr);
    const guint psize = gv ? arv_camera_gv_get_packet_size(camera_, nullptr) : 0;
    const gint64 pdelay = gv ? arv_camera_gv_get_packet_delay(camera_, nullptr) : 0;
    log::info("camera", "{}: {} {}x{}+{}+{}, exposure {} us, gain {}, trigger {} ({}), packet {} B, delay {} ns, resend {}",
              describe(), pf ? pf : "?", rw, rh, x, y, exp, gain, config::triggerModeName(cfg_.trigger),
              src ? src : "-", psize, pdelay, cfg_.packetResend ? "on" : "off");
    return {};
  }

  // Depth cameras (SFNC Scan3dControl): read the features that say how a raw Coord3D_C16
  // value becomes mm and what the intrinsics are, refuse what cannot be used (naming the
  // feature), log them, and turn on multipart (range + confidence) when the camera offers it.
  Result<void> applyDepthFeatures() {
    GError* err = nullptr;
    auto has = [&](const char* f) { return static_cast<bool>(arv_camera_is_feature_available(camera_, f, nullptr)); };
    if (has("Scan3dCoordinateSelector")) {
      arv_camera_set_string(camera_, "Scan3dCoordinateSelector", "CoordinateC", &err);
      if (err) return failSetting("pixel_format", "cannot set Scan3dCoordinateSelector=CoordinateC: " + takeMessage(err));
    }
    Scan3dFeatures f;
    std::string readError;
    auto text = [&](const char* name) -> std::string {
      if (!has(name)) return {};
      const char* v = arv_camera_get_string(camera_, name, &err);
      if (err) readError = std::string(name) + ": " + takeMessage(err);
      return v ? v : "";
    };
    auto number = [&](const char* name) -> std::optional<double> {
      if (!has(name)) return std::nullopt;
      const double v = arv_camera_get_float(camera_, name, &err);
      if (err) {
        readError = std::string(name) + ": " + takeMessage(err);
        return std::nullopt;
      }
      return v;
    };
    f.distanceUnit = text("Scan3dDistanceUnit");
    f.coordinateSystem = text("Scan3dCoordinateSystem");
    f.outputMode = text("Scan3dOutputMode");
    f.scale = number("Scan3dCoordinateScale");
    f.offset = number("Scan3dCoordinateOffset");
    if (has("Scan3dInvalidDataFlag")) {
      f.invalidFlag = arv_camera_get_boolean(camera_, "Scan3dInvalidDataFlag", &err) != FALSE;
      if (err) readError = "Scan3dInvalidDataFlag: " + takeMessage(err);
    }
    f.invalidValue = number("Scan3dInvalidDataValue");
    f.focalLength = number("Scan3dFocalLength");
    f.principalPointU = number("Scan3dPrincipalPointU");
    f.principalPointV = number("Scan3dPrincipalPointV");
    if (!readError.empty()) return failSetting("pixel_format", "cannot read " + readError);
    auto encoding = depthEncoding(f);
    if (!encoding) return failSetting("pixel_format", "Coord3D_C16: " + encoding.error().message);
    depth_ = *encoding;
    multipart_ = false;
    std::string parts = "single part";
    if (arv_camera_is_gv_device(camera_)) {
      const bool offered = arv_camera_gv_is_multipart_supported(camera_, &err) != FALSE;
      if (err) g_clear_error(&err);  // a camera without the multipart capability register
      if (offered) {
        // Range on, confidence on when offered (pixels it marks 0 have no data), the rest off.
        if (has("ComponentSelector") && has("ComponentEnable")) {
          for (const char* component : {"Range", "Confidence", "Intensity"}) {
            if (!arv_camera_is_enumeration_entry_available(camera_, "ComponentSelector", component, nullptr)) continue;
            arv_camera_set_string(camera_, "ComponentSelector", component, &err);
            if (!err) arv_camera_set_boolean(camera_, "ComponentEnable", std::string(component) != "Intensity", &err);
            if (err) return failSetting("pixel_format", std::string("cannot enable the ") + component + " component: " + takeMessage(err));
          }
        }
        arv_camera_gv_set_multipart(camera_, TRUE, &err);
        if (err) return failSetting("pixel_format", "cannot turn on GigE multipart: " + takeMessage(err));
        multipart_ = true;
        parts = "multipart (range + confidence)";
      }
    }
    log::info("camera", "{}: depth {}, {}", describe(), drivers::describe(f, depth_), parts);
    return {};
  }

  CameraStats streamStats() const {
    CameraStats s;
    if (!stream_) return s;
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(stream_, &completed, &failures, &underruns);
    s.underruns = underruns;
    if (ARV_IS_GV_STREAM(stream_)) {
      guint64 resent = 0, missing = 0;
      arv_gv_stream_get_statistics(ARV_GV_STREAM(stream_), &resent, &missing);
      s.resentPackets = resent;
      s.missingPackets = missing;
    }
    return s;
  }

  Result<void> setStatus(FrameStatus st, const std::string& what) {
    lastStatus_ = st;
    return fail(st == FrameStatus::IllegalState ? Status::Internal : Status::CameraError,
                describe() + ": " + what + " (" + frameStatusName(st) + ")");
  }

  Result<void> acquire(Frame& out, milliseconds timeout) {
    if (state_ != CameraState::Streaming) return setStatus(FrameStatus::IllegalState, "trigger while not streaming");
    if (controlLost_) return setStatus(FrameStatus::Disconnected, "control channel lost");
    const auto deadline = Clock::now() + timeout;
    std::uint64_t notBeforeNs = 0;  // host time before which a frame cannot be this request's
    switch (cfg_.trigger) {
      case config::TriggerMode::Software: {
        // Frames that arrived late for an earlier trigger are not this trigger's.
        while (ArvBuffer* stale = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, stale);
        notBeforeNs = wallNs();
        GError* err = nullptr;
        arv_camera_software_trigger(camera_, &err);
        if (err) {
          deviceGone_ = true;
          return setStatus(FrameStatus::Disconnected, "software trigger failed: " + takeMessage(err));
        }
        break;
      }
      case config::TriggerMode::Hardware:
        // The line may have fired just before the cycle asked: frames up to `timeout` old count.
        notBeforeNs = wallNs() - static_cast<std::uint64_t>(timeout.count()) * 1000000ull;
        break;
      case config::TriggerMode::FreeRun:
        // Only the latest frame is of interest: recycle everything queued.
        while (ArvBuffer* stale = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, stale);
        break;
    }
    ArvBuffer* buf = nullptr;
    bool skippedDamaged = false;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now()).count();
      if (left <= 0) break;
      buf = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(left));
      if (!buf) break;
      if (arv_buffer_get_system_timestamp(buf) < notBeforeNs) {
        arv_stream_push_buffer(stream_, buf);  // an older trigger's frame
        buf = nullptr;
        continue;
      }
      // Free-run: the camera keeps sending, so a damaged frame is skipped for the next one.
      if (cfg_.trigger == config::TriggerMode::FreeRun && arv_buffer_get_status(buf) != ARV_BUFFER_STATUS_SUCCESS) {
        arv_stream_push_buffer(stream_, buf);
        buf = nullptr;
        skippedDamaged = true;
        continue;
      }
      break;
    }
    if (!buf && skippedDamaged) return setStatus(FrameStatus::Incomplete, "only damaged frames within " + std::to_string(timeout.count()) + " ms");
    if (!buf) {
      if (controlLost_) return setStatus(FrameStatus::Disconnected, "control channel lost");
      // A camera that restarted answers commands but no longer streams to us; one that died
      // fails the read (after ~2.5 s). Either way it is not a lost frame but a lost device.
      if (std::string why; !controlHeld(why)) return setStatus(FrameStatus::Disconnected, why);
      return setStatus(FrameStatus::Timeout, "no frame within " + std::to_string(timeout.count()) + " ms");
    }
    const ArvBufferStatus st = arv_buffer_get_status(buf);
    if (st != ARV_BUFFER_STATUS_SUCCESS) {
      const std::uint64_t id = arv_buffer_get_frame_id(buf);
      arv_stream_push_buffer(stream_, buf);
      const FrameStatus fs = (st == ARV_BUFFER_STATUS_TIMEOUT || st == ARV_BUFFER_STATUS_MISSING_PACKETS ||
                              st == ARV_BUFFER_STATUS_WRONG_PACKET_ID)
                                 ? FrameStatus::Incomplete
                             : st == ARV_BUFFER_STATUS_ABORTED ? FrameStatus::Disconnected
                                                               : FrameStatus::Failed;
      return setStatus(fs, "frame " + std::to_string(id) + " lost (Aravis buffer status " + std::to_string(st) + ")");
    }
    auto r = convert(buf, out);
    arv_stream_push_buffer(stream_, buf);
    if (!r) return r;
    lastStatus_ = FrameStatus::Ok;
    return {};
  }

  Result<void> convertDepthBuffer(ArvBuffer* buf, Frame& out) {
    std::vector<BufferPart>& parts = parts_;  // reused: no allocation once warm
    parts.clear();
    if (arv_buffer_get_payload_type(buf) == ARV_BUFFER_PAYLOAD_TYPE_MULTIPART) {
      for (guint i = 0; i < arv_buffer_get_n_parts(buf); ++i) {
        BufferPart p;
        size_t size = 0;
        p.data = static_cast<const std::uint8_t*>(arv_buffer_get_part_data(buf, i, &size));
        p.size = size;
        p.width = arv_buffer_get_part_width(buf, i);
        p.height = arv_buffer_get_part_height(buf, i);
        p.pixelFormat = static_cast<std::uint32_t>(arv_buffer_get_part_pixel_format(buf, i));
        p.dataType = static_cast<int>(arv_buffer_get_part_data_type(buf, i));
        parts.push_back(p);
      }
    } else {
      BufferPart p;
      size_t size = 0;
      p.data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buf, &size));
      p.size = size;
      p.width = arv_buffer_get_image_width(buf);
      p.height = arv_buffer_get_image_height(buf);
      p.pixelFormat = static_cast<std::uint32_t>(arv_buffer_get_image_pixel_format(buf));
      p.dataType = 5;  // 3D image
      parts.push_back(p);
    }
    auto which = selectDepthParts(parts);
    if (!which) return setStatus(FrameStatus::Failed, "unexpected frame: " + which.error().message);
    const BufferPart& range = parts[which->range];
    const BufferPart* confidence = which->confidence ? &parts[*which->confidence] : nullptr;
    if (auto r = convertDepth(range, confidence, depth_, out.data); !r)
      return setStatus(FrameStatus::Failed, "unexpected frame: " + r.error().message);
    out.width = range.width;
    out.height = range.height;
    out.pixel = PixelType::DepthMm;
    out.bitDepth = 32;
    out.intrinsics = depth_.intrinsics;
    out.intrinsics.width = out.width;
    out.intrinsics.height = out.height;
    out.frameId = arv_buffer_get_frame_id(buf);
    out.deviceTimestampNs = arv_buffer_get_timestamp(buf);
    out.hostTimestampNs = arv_buffer_get_system_timestamp(buf);
    if (out.hostTimestampNs == 0) out.hostTimestampNs = wallNs();
    return {};
  }

  Result<void> convert(ArvBuffer* buf, Frame& out) {
    if (format_->out == PixelType::DepthMm) return convertDepthBuffer(buf, out);
    size_t size = 0;
    const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buf, &size));
    const int w = arv_buffer_get_image_width(buf), h = arv_buffer_get_image_height(buf);
    const ArvPixelFormat pf = arv_buffer_get_image_pixel_format(buf);
    const int bpp = format_->out == PixelType::Mono16 ? 2 : 1;
    const size_t need = static_cast<size_t>(w) * h * bpp;
    if (pf != format_->arv || w <= 0 || h <= 0 || size < need)
      return setStatus(FrameStatus::Failed, "unexpected frame: pixel format 0x" + fmt::format("{:x}", pf) + ", " +
                                                std::to_string(w) + "x" + std::to_string(h) + ", " + std::to_string(size) + " bytes");
    out.data.resize(need);  // no reallocation once warm
    if (format_->bayerToGray >= 0) {
      const cv::Mat src(h, w, CV_8UC1, const_cast<std::uint8_t*>(data));
      cv::Mat dst(h, w, CV_8UC1, out.data.data());
      cv::cvtColor(src, dst, format_->bayerToGray);
    } else {
      std::memcpy(out.data.data(), data, need);  // GVSP Mono16 is little-endian, as our hosts
    }
    out.width = w;
    out.height = h;
    out.pixel = format_->out;
    out.bitDepth = format_->bits;
    out.frameId = arv_buffer_get_frame_id(buf);
    out.deviceTimestampNs = arv_buffer_get_timestamp(buf);
    out.hostTimestampNs = arv_buffer_get_system_timestamp(buf);
    if (out.hostTimestampNs == 0) out.hostTimestampNs = wallNs();
    return {};
  }

  config::CameraConfig cfg_;
  const FormatInfo* format_;
  std::string address_;  // where the camera was last found (empty: opened by user name)
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  CameraState state_ = CameraState::Closed;
  FrameStatus lastStatus_ = FrameStatus::Ok;
  std::atomic<bool> controlLost_{false};
  bool deviceGone_ = false;  // a GVCP command failed: skip further commands when closing
  CameraStats stats_;        // frame counters (this object)
  CameraStats streamBase_;   // packet counters of streams already destroyed
  gint width_ = 0, height_ = 0;
  DepthEncoding depth_;      // Coord3D_C16: read from the Scan3d features on every open
  bool multipart_ = false;   // the camera sends range (+ confidence) as GigE multipart
  std::vector<BufferPart> parts_;  // convertDepthBuffer's scratch (acquisition thread)
};

}  // namespace

std::unique_ptr<Camera> makeAravisCamera(const config::CameraConfig& config) {
  return std::make_unique<AravisCamera>(config);
}

std::vector<DiscoveredCamera> discoverCameras() {
  arv_update_device_list();
  std::vector<DiscoveredCamera> out;
  auto s = [](const char* p) { return std::string(p ? p : ""); };
  for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
    out.push_back({s(arv_get_device_id(i)), s(arv_get_device_vendor(i)), s(arv_get_device_model(i)),
                   s(arv_get_device_serial_nbr(i)), s(arv_get_device_address(i)), s(arv_get_device_protocol(i))});
  }
  return out;
}

bool probeGigECamera(const std::string& address, milliseconds timeout) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(3956);
  if (::inet_pton(AF_INET, address.c_str(), &sa.sin_addr) != 1) return false;
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  bool ok = false;
  // GVCP DISCOVERY_CMD (GigE Vision 2.0, 16.1.1): key 0x42, flags "ack required", command
  // 0x0002, no payload, request id 1. connect() so only that address's answer is read.
  const std::uint8_t cmd[8] = {0x42, 0x11, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01};
  if (::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) == 0 && ::send(fd, cmd, sizeof cmd, 0) == sizeof cmd) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<milliseconds>(end - Clock::now()).count();
      if (left <= 0) break;
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) break;
      std::uint8_t ack[600];
      const ssize_t n = ::recv(fd, ack, sizeof ack, 0);
      if (n < 0) break;  // ECONNREFUSED: nobody listens there
      if (n >= 8 && ack[2] == 0x00 && ack[3] == 0x03) {  // DISCOVERY_ACK
        ok = true;
        break;
      }
    }
  }
  ::close(fd);
  return ok;
}

}  // namespace vgr::drivers
