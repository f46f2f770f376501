// The commissioning page (docs/commissioning.md): what an integrator looks at while bringing
// a cell up, served by vgrd's web server (daemon/web_server.hpp) next to /metrics.
//
//   GET  /                    the page (daemon/web/index.html, embedded at build time)
//   GET  /api/status          cell, READY, jobs, camera counters, calibration files with
//                             their residuals and age, per-stage times, archive, WebSocket
//                             clients, and `sections` (the extension point, below)
//   GET  /api/cycles?n=N      the last N (<= 200) cycles, newest first, each exactly its
//                             journal line (Journal::toJson)
//   GET  /api/live.jpg        the last cycle's image with its overlay (vision/overlay.hpp); a 3D
//                             cycle's depth frame in false colour with its parts' axes and a
//                             colour bar (header X-Vgr-Depth-Mm: "near,far", the z range)
//   GET  /api/archive         the archived frames, newest first (?n=, <= 1000)
//   GET  /api/archive.jpg?name=STEM.png   an archived cycle's frame with its overlay
//   GET  /ws                  WebSocket: {"type":"cycle","cycle":<journal line>} for every
//                             cycle as it ends; the live picture of cycle N as soon as it is
//                             drawn, as one binary message: {"type":"image","cycle":N,
//                             "scale":s[,"depth_mm":[near,far]]} '\n' JPEG; {"type":"status",...}
//                             on connect
//   POST /api/trigger?job=N   operator actions (web.actions, from web.allowed_clients only,
//   POST /api/job?id=N        with the header X-Vgr-Action: 1): a cycle of job N (0 or none =
//                             the default job); switch the default job. 403 otherwise.
//   POST /api/repeatability?...  the figures of a live `vgr repeatability` run (a
//                             measurement: from loopback or web.allowed_clients, header
//                             X-Vgr-Action: 1, web.actions not needed); kept in
//                             <journal folder>/repeatability.json and shown as
//                             /api/status -> sections.repeatability (repeatability_record.hpp)
//
// Cost to the cycle thread (frameDone): one copy of the gray image (a 3D cycle: of the depth
// frame, 4 bytes a pixel) into a free one of three preallocated buffers (no allocation once
// warm) and one post of the result to the I/O thread. Overlay drawing (for a depth frame
// also its false colours, vision/overlay.hpp colourDepth) and JPEG encoding run on the
// page's render thread, only while a WebSocket client watches (then once per cycle) or when
// an image is asked for; JSON is built on the I/O thread. Nothing is logged per cycle.
//
// Extension point, for figures other parts of vgrd compute (the drift monitor, the
// repeatability run, ...): addStatusSection(name, fill) before start(). `fill` runs on the
// I/O thread for every /api/status and every status push (each cycle's end, throttled to 1
// per second) and writes a JSON object into its argument; it appears as
// /api/status -> sections.<name>, and the page shows every section as a table of its
// fields (nested objects flattened as a.b), so a new section needs no page change. `fill`
// must be quick and must not block (read atomics or a snapshot under a short lock).
//
// Threads: construct, addStatusSection(), start() and stop() on the main/I/O thread;
// frameDone() on the cycle thread; everything else on the I/O thread and the render thread.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "daemon/cycle_image.hpp"

namespace boost::asio {
class io_context;
}
namespace vgr::drivers {
class CameraWorker;
}

namespace vgr::daemon {

class ImageArchive;
class WebServer;

// What the page reads and acts on; borrowed, outliving start()..stop().
struct WebPageSources {
  const config::CellConfig* cell = nullptr;
  std::string version;
  const drivers::CameraWorker* camera = nullptr;
  const ImageArchive* archive = nullptr;  // null: no archive
  std::function<bool()> ready;                              // READY as the PLC sees it
  std::function<std::uint32_t(int jobId)> trigger;          // an operator cycle; 0 = refused (queue full)
  std::function<Result<void>(int jobId)> setDefaultJob;     // the page's "switch job"
  std::function<int()> defaultJob;
};

// Writes one section's fields: out is a JSON object (empty on entry).
using StatusSection = std::function<void(nlohmann::json& out)>;

class WebPage {
 public:
  WebPage(boost::asio::io_context& io, WebServer& server, const config::WebConfig& web, WebPageSources sources);
  ~WebPage();  // stop()
  WebPage(const WebPage&) = delete;
  WebPage& operator=(const WebPage&) = delete;

  // The extension point (see above). Before start(); a name used twice replaces the first.
  void addStatusSection(const std::string& name, StatusSection fill);
  // Registers the routes and the WebSocket on the server (before the server starts) and
  // starts the render thread.
  void start();
  void stop();

  // Cycle thread, once per cycle: the frame as the locator saw it (empty: no frame).
  void frameDone(const CycleResult& r, const CycleImage& image);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::daemon
