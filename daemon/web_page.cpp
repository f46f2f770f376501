#include "daemon/web_page.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/log.hpp"
#include "core/pose.hpp"
#include "daemon/image_archive.hpp"
#include "daemon/job_locator.hpp"
#include "daemon/journal.hpp"
#include "daemon/repeatability_record.hpp"
#include "daemon/web_server.hpp"
#include "drivers/camera_worker.hpp"
#include "vision/overlay.hpp"

namespace vgr::daemon {

// The page's HTML (daemon/web/index.html), embedded at build time.
const std::string& embeddedWebPageHtml();

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr std::size_t kRecentCycles = 200;   // kept for /api/cycles and the page's table
constexpr std::size_t kStageWindow = 100;    // cycles the stage times are summarised over
constexpr std::size_t kRenderQueue = 16;     // image requests waiting for the render thread
constexpr int kJpegQuality = 85;
constexpr auto kStatusPushEvery = std::chrono::seconds(1);
const char* kJsonType = "application/json";

HttpReply jsonReply(int status, const json& j) { return {status, kJsonType, j.dump() + "\n", {}}; }
HttpReply errorReply(int status, const std::string& why) { return jsonReply(status, json{{"error", why}}); }

// A calibration file as the page shows it: its kind, the residuals it was accepted with
// (every top-level number whose key names an rms or a residual) and when it was written.
struct CalibFile {
  std::string role;  // "intrinsics", "handeye", "plane", "multiheight"
  std::string path;
  std::string kind;  // its calibration_kind
  std::map<std::string, double> residuals;
  std::string error;  // why it could not be read ("" = read)
  fs::file_time_type modifiedAtStart{};
};

CalibFile readCalibFile(const std::string& role, const std::string& path) {
  CalibFile c;
  c.role = role;
  c.path = path;
  std::error_code ec;
  c.modifiedAtStart = fs::last_write_time(path, ec);
  try {
    cv::FileStorage fsIn(path, cv::FileStorage::READ);
    if (!fsIn.isOpened()) {
      c.error = "cannot open it";
      return c;
    }
    const cv::FileNode root = fsIn.root();
    for (auto it = root.begin(); it != root.end(); ++it) {
      const cv::FileNode n = *it;
      const std::string key = n.name();
      if (key == "calibration_kind" && n.isString()) c.kind = n.string();
      if ((n.isReal() || n.isInt()) && (key.find("rms") != std::string::npos || key.find("resid") != std::string::npos))
        c.residuals[key] = n.real();
    }
  } catch (const cv::Exception& e) {
    c.error = e.what();
  }
  return c;
}

double seconds(fs::file_time_type t) {
  return std::chrono::duration<double>(t - fs::file_time_type::clock::now()).count() * -1.0;
}

struct Stage {
  double grab, locate, total;
};

json summary(std::vector<double> v, double last) {
  if (v.empty()) return nullptr;
  std::sort(v.begin(), v.end());
  return {{"last", last}, {"median", v[v.size() / 2]}, {"max", v.back()}, {"n", v.size()}};
}

}  // namespace

struct WebPage::Impl {
  Impl(boost::asio::io_context& ioIn, WebServer& serverIn, const config::WebConfig& w, WebPageSources s)
      : io(ioIn), server(serverIn), web(w), src(std::move(s)) {}

  boost::asio::io_context& io;
  WebServer& server;
  const config::WebConfig web;
  WebPageSources src;
  std::map<std::string, StatusSection> sections;
  std::map<int, vision::OverlayJob> overlayJobs;  // by job id, built at start (read-only after)
  std::vector<CalibFile> calib;                   // read at start (what vgrd loaded)
  // The last live `vgr repeatability` run (daemon/repeatability_record.hpp); I/O thread.
  std::string repeatPath;
  std::optional<RepeatabilityRun> repeat;
  std::string repeatError;  // the record file at start did not read

  // I/O thread.
  std::deque<std::string> recent;  // journal lines, newest first
  std::deque<Stage> stages;        // newest last
  std::map<std::string, std::uint64_t> byStatus;
  std::uint64_t cycles = 0;
  Clock::time_point lastStatusPush{};

  // The live image: the cycle thread writes a slot that is neither the latest nor the one
  // being rendered (three slots: one is always free), the render thread reads `latest`.
  struct LiveSlot {
    cv::Mat image;  // gray, or a 3D cycle's depth frame (depth: CV_32FC1 mm, with its intrinsics and T_base_cam)
    bool depth = false;
    DepthIntrinsics intrinsics;
    Pose baseFromCamera;
    CycleResult result;
  };
  std::array<LiveSlot, 3> live;
  std::mutex mutex;  // live indices, requests, the cached JPEG
  std::condition_variable cv;
  int latest = -1, busy = -1;
  std::uint64_t liveSeq = 0, renderedSeq = 0;
  // A drawn picture: the JPEG, its cycle, JPEG px per image px, and a depth picture's z range.
  struct Picture {
    std::shared_ptr<const std::string> jpeg;
    std::uint32_t cycle = 0;
    double scale = 1;
    std::optional<vision::DepthColourRange> depthMm;
  };
  Picture live_;  // the last live picture (jpeg null: none yet)
  struct Request {
    std::string archiveName;  // "" = the live image
    HttpRespond respond;
  };
  std::deque<Request> requests;
  bool stopping = false;
  std::thread renderThread;

  // ---- render thread ------------------------------------------------------------------
  cv::Mat depthColours;  // a depth frame's false colours (render thread; reused)

  std::string encode(const cv::Mat& gray, const vision::OverlayFrame& f) const {
    cv::Mat img = gray;
    if (img.empty()) img = cv::Mat(480, 640, CV_8UC1, cv::Scalar(24));  // a cycle without a frame: its caption alone
    const cv::Mat drawn = vision::drawOverlay(img, f, vision::overlayScaleFor(img.cols, web.liveMaxWidth));
    std::vector<uchar> buf;
    cv::imencode(".jpg", drawn, buf, {cv::IMWRITE_JPEG_QUALITY, kJpegQuality});
    return std::string(buf.begin(), buf.end());
  }

  // The live picture of a slot: the gray image with its overlay, or a 3D cycle's depth frame
  // in false colour (near red .. far blue, no data black, a colour bar in mm) with each
  // part's grasp frame projected (T_cam_grasp = T_base_cam^-1 * the part's base-frame pose).
  Picture render(const LiveSlot& s) {
    Picture p;
    p.cycle = s.result.cycleId;
    p.scale = scaleFor(s.image);
    if (!s.depth || s.image.empty()) {
      const auto f = overlayOf(s.result.cycleId, s.result.jobId, s.result.status, vision::overlayParts(s.result.parts));
      p.jpeg = std::make_shared<const std::string>(encode(s.image, f));
      return p;
    }
    std::vector<vision::OverlayPart> parts;
    parts.reserve(s.result.parts.size());
    const Pose camFromBase = inverse(s.baseFromCamera);
    for (const auto& part : s.result.parts)
      parts.push_back(vision::overlayPart3d(compose(camFromBase, part.pose), s.intrinsics, part.score));
    vision::OverlayFrame f = overlayOf(s.result.cycleId, s.result.jobId, s.result.status, std::move(parts));
    f.job = {};  // a 2D job's ROI and template mean nothing on a depth frame
    f.depthRange = vision::colourDepth(s.image, depthColours);
    p.depthMm = f.depthRange;
    p.jpeg = std::make_shared<const std::string>(encode(depthColours, f));
    return p;
  }

  vision::OverlayFrame overlayOf(std::uint32_t cycle, int job, Status status, std::vector<vision::OverlayPart> parts) const {
    vision::OverlayFrame f;
    if (const auto it = overlayJobs.find(job); it != overlayJobs.end()) f.job = it->second;
    f.caption = vision::cycleCaption(cycle, job, status, parts.size());
    f.ok = status == Status::Ok;
    f.parts = std::move(parts);
    return f;
  }

  // X-Vgr-Cycle: the cycle drawn; X-Vgr-Scale: JPEG px per image px; a depth picture's
  // X-Vgr-Depth-Mm: "near,far", the z its colour bar spans.
  static HttpReply jpegReply(const Picture& p) {
    HttpReply r{200, "image/jpeg", *p.jpeg, {}};
    r.headers.push_back({"X-Vgr-Cycle", std::to_string(p.cycle)});
    r.headers.push_back({"X-Vgr-Scale", fmt::format("{:.6f}", p.scale)});
    if (p.depthMm) r.headers.push_back({"X-Vgr-Depth-Mm", fmt::format("{:.3f},{:.3f}", p.depthMm->nearMm, p.depthMm->farMm)});
    return r;
  }
  double scaleFor(const cv::Mat& gray) const { return gray.empty() ? 1.0 : vision::overlayScaleFor(gray.cols, web.liveMaxWidth); }

  HttpReply renderArchived(const std::string& name) const {
    if (!src.archive) return errorReply(404, "no image archive (the cell config has no 'archive' section)");
    if (!isArchiveName(name, ".png")) return errorReply(400, "name: expected an archived frame's file name, e.g. 20261202-101530.123-c17.png");
    const fs::path png = fs::path(src.archive->dir()) / name;
    const fs::path side = fs::path(src.archive->dir()) / (name.substr(0, name.size() - 4) + ".json");
    const cv::Mat gray = cv::imread(png.string(), cv::IMREAD_GRAYSCALE);
    if (gray.empty()) return errorReply(404, name + ": not in the archive (deleted for the quota, or never written)");
    std::ifstream in(side);
    std::string line;
    std::getline(in, line);
    const json j = json::parse(line, nullptr, false);
    if (!j.is_object()) return errorReply(500, side.filename().string() + ": the cycle's journal line cannot be read");
    std::vector<vision::OverlayPart> parts;
    for (const auto& p : j.value("parts", json::array()))
      parts.push_back({p.value("u_px", 0.0), p.value("v_px", 0.0), p.value("angle_img_deg", 0.0), p.value("score", 0.0),
                       p.value("label", 0), p.value("confidence", 0.0)});
    const auto f = overlayOf(j.value("cycle", 0u), j.value("job", 0), static_cast<Status>(j.value("status", -8)), std::move(parts));
    return jpegReply({std::make_shared<const std::string>(encode(gray, f)), j.value("cycle", 0u), scaleFor(gray), std::nullopt});
  }

  void renderLoop() {
    for (;;) {
      std::unique_lock lock(mutex);
      cv.wait(lock, [this] {
        return stopping || !requests.empty() ||
               (latest >= 0 && liveSeq != renderedSeq && server.websocketCounters().clients > 0);
      });
      if (stopping) {
        for (auto& r : requests) r.respond(errorReply(503, "vgrd is stopping"));
        requests.clear();
        return;
      }
      if (!requests.empty() && !requests.front().archiveName.empty()) {
        Request r = std::move(requests.front());
        requests.pop_front();
        lock.unlock();
        r.respond(renderArchived(r.archiveName));
        continue;
      }
      std::vector<HttpRespond> waiting;
      while (!requests.empty() && requests.front().archiveName.empty()) {
        waiting.push_back(std::move(requests.front().respond));
        requests.pop_front();
      }
      const bool fresh = latest >= 0 && liveSeq != renderedSeq;
      if (fresh) {
        busy = latest;
        const std::uint64_t seq = liveSeq;
        lock.unlock();
        Picture drawn = render(live[static_cast<std::size_t>(busy)]);
        lock.lock();
        busy = -1;
        live_ = std::move(drawn);
        renderedSeq = seq;
      }
      const Picture pic = live_;
      lock.unlock();
      for (auto& w : waiting) w(pic.jpeg ? jpegReply(pic) : errorReply(404, "no cycle yet"));
      if (fresh) {
        // The picture itself to every watching page, in one binary message: a JSON line
        // {"type":"image","cycle","scale"[,"depth_mm"]}, '\n', the JPEG (no second round trip).
        json meta{{"type", "image"}, {"cycle", pic.cycle}, {"scale", pic.scale}};
        if (pic.depthMm) meta["depth_mm"] = {std::round(pic.depthMm->nearMm * 1000) / 1000, std::round(pic.depthMm->farMm * 1000) / 1000};
        std::string msg = meta.dump() + "\n";
        msg += *pic.jpeg;
        boost::asio::post(io, [this, m = std::move(msg)]() mutable { server.broadcastBinary(std::move(m)); });
      }
    }
  }

  void request(Request r) {
    {
      std::lock_guard lock(mutex);
      if (requests.size() < kRenderQueue && !stopping) {
        requests.push_back(std::move(r));
        cv.notify_one();
        return;
      }
    }
    r.respond(errorReply(503, "too many image requests waiting"));
  }

  // ---- I/O thread ---------------------------------------------------------------------
  bool allowed(const std::string& remote) const {
    return std::find(web.allowedClients.begin(), web.allowedClients.end(), remote) != web.allowedClients.end();
  }

  void onCycle(const CycleResult& r) {
    std::string line = Journal::toJson(r);
    ++cycles;
    ++byStatus[std::string(statusName(r.status))];
    stages.push_back({r.grabMs, r.locateMs, r.totalMs});
    if (stages.size() > kStageWindow) stages.pop_front();
    server.broadcast("{\"type\":\"cycle\",\"cycle\":" + line + "}");
    recent.push_front(std::move(line));
    if (recent.size() > kRecentCycles) recent.pop_back();
    const auto now = Clock::now();
    if (now - lastStatusPush >= kStatusPushEvery && server.websocketCounters().clients > 0) {
      lastStatusPush = now;
      json st = status("");
      st["type"] = "status";
      server.broadcast(st.dump());
    }
  }

  json status(const std::string& client) const {
    json j;
    const config::CellConfig& cell = *src.cell;
    j["cell"] = cell.name;
    j["version"] = src.version;
    j["time"] = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    j["ready"] = src.ready ? src.ready() : false;
    j["default_job"] = src.defaultJob ? src.defaultJob() : 0;
    j["web"] = {{"actions", web.actions}};
    if (!client.empty()) {
      j["web"]["client"] = client;
      j["web"]["client_allowed"] = web.actions && allowed(client);
    }
    json jobs = json::array();
    for (const auto& job : cell.jobs) {
      json e{{"id", job.id}, {"name", job.name}, {"method", job.method}, {"folder", job.folder},
             {"part_height_mm", job.partHeightMm},
             {"reference", {{"x_mm", job.reference.x}, {"y_mm", job.reference.y}, {"z_mm", job.reference.z}, {"rz_deg", job.reference.rzDeg}}}};
      if (const auto it = overlayJobs.find(job.id); it != overlayJobs.end() && !it->second.searchRoi.empty()) {
        const auto& roi = it->second.searchRoi;
        e["search_roi"] = {roi.x, roi.y, roi.width, roi.height};
      }
      jobs.push_back(std::move(e));
    }
    j["jobs"] = std::move(jobs);
    if (src.camera) {
      const drivers::CameraCounters c = src.camera->counters();
      j["camera"] = {{"name", cell.camera.name}, {"streaming", src.camera->streaming()}, {"frames", c.completed},
                     {"failed", c.failed}, {"timeouts", c.timeouts}, {"incomplete", c.incomplete}, {"retriggers", c.retries},
                     {"recovered", c.recovered}, {"abandoned", c.abandoned}, {"reconnects", c.reconnects},
                     {"packets_missing", c.missingPackets}, {"packets_resent", c.resentPackets}, {"underruns", c.underruns}};
    }
    json cyc{{"total", cycles}, {"by_status", byStatus}};
    cyc["last"] = recent.empty() ? json(nullptr) : json::parse(recent.front(), nullptr, false);
    j["cycles"] = std::move(cyc);
    std::vector<double> g, l, t;
    for (const auto& s : stages) g.push_back(s.grab), l.push_back(s.locate), t.push_back(s.total);
    j["stages_ms"] = {{"grab", summary(g, stages.empty() ? 0 : stages.back().grab)},
                      {"locate", summary(l, stages.empty() ? 0 : stages.back().locate)},
                      {"total", summary(t, stages.empty() ? 0 : stages.back().total)}};
    json cal = json::array();
    if (calib.empty()) cal.push_back({{"role", "model"}, {"path", cell.sourcePath}, {"kind", "pinhole model (cell config 'model')"}});
    for (const auto& c : calib) {
      json e{{"role", c.role}, {"path", c.path}, {"kind", c.kind}, {"residuals", c.residuals}};
      std::error_code ec;
      const auto now = fs::last_write_time(c.path, ec);
      if (!ec) {
        e["age_s"] = std::round(seconds(now));
        e["changed_since_start"] = now != c.modifiedAtStart;
      }
      if (!c.error.empty()) e["error"] = c.error;
      cal.push_back(std::move(e));
    }
    j["calibration"] = std::move(cal);
    if (src.archive) {
      const ArchiveCounters a = src.archive->counters();
      j["archive"] = {{"dir", src.archive->dir()}, {"files", a.files}, {"bytes", a.bytes}, {"quota_bytes", a.quotaBytes},
                      {"written", a.written}, {"dropped", a.dropped}, {"deleted", a.deleted}, {"write_errors", a.writeErrors},
                      {"queued", a.queued}};
    } else {
      j["archive"] = nullptr;
    }
    const WebSocketCounters w = server.websocketCounters();
    j["websocket"] = {{"clients", w.clients}, {"dropped", w.dropped}};
    json secs = json::object();
    for (const auto& [name, fill] : sections) {
      json s = json::object();
      fill(s);
      secs[name] = std::move(s);
    }
    json rep = json::object();
    if (repeat) rep = toJson(*repeat);
    else if (!repeatError.empty()) rep["error"] = repeatError;
    else rep["state"] = "no run recorded (vgr repeatability records its live runs here)";
    rep["file"] = repeatPath;
    secs["repeatability"] = std::move(rep);
    j["sections"] = std::move(secs);
    return j;
  }

  // POST /api/repeatability: a measurement, not an operator action (web.actions may be off),
  // from the IPC itself or an address in web.allowed_clients, with the page's header.
  HttpReply recordRepeatability(const HttpRequest& req) {
    const bool loopback = req.remote.rfind("127.", 0) == 0 || req.remote == "::1";
    if (!loopback && !allowed(req.remote)) {
      log::warn("web", "repeatability record refused: {} is neither loopback nor in web.allowed_clients", req.remote);
      return errorReply(403, "address " + req.remote + " is neither loopback nor in web.allowed_clients");
    }
    if (req.header("x-vgr-action") != "1") return errorReply(403, "missing header 'X-Vgr-Action: 1'");
    auto run = fromQuery([&req](const std::string& k) { return req.param(k); });
    if (!run) return errorReply(400, run.error().message);
    if (src.cell->findJob(run->job) == nullptr) return errorReply(400, fmt::format("job {} is not configured", run->job));
    run->at = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    run->from = req.remote;
    if (auto w = writeRepeatabilityRecord(repeatPath, *run); !w) {
      log::warn("web", "repeatability record: {}", w.error().message);
      return errorReply(500, w.error().message);
    }
    repeat = std::move(*run);
    repeatError.clear();
    log::info("web", "repeatability run recorded from {}: job {}, {} shots, sigma {:.4f} mm / {:.4f} deg, {}", req.remote,
              repeat->job, repeat->shots, maxSigmaMm(*repeat), maxSigmaDeg(*repeat), repeat->pass ? "pass" : "FAIL");
    return jsonReply(200, toJson(*repeat));
  }

  HttpReply action(const HttpRequest& req, const std::string& what, const std::function<HttpReply()>& act) const {
    if (!web.actions) return errorReply(403, "operator actions are off (web.actions: false in the cell config)");
    if (!allowed(req.remote)) {
      log::warn("web", "operator {} refused: {} is not in web.allowed_clients", what, req.remote);
      return errorReply(403, "address " + req.remote + " is not in web.allowed_clients");
    }
    if (req.header("x-vgr-action") != "1")
      return errorReply(403, "missing header 'X-Vgr-Action: 1' (the page sends it; it keeps other sites' pages from acting)");
    return act();
  }

  static bool parseInt(const std::string& text, int& out) {
    if (text.empty() || text.size() > 6) return false;
    int v = 0;
    for (char c : text) {
      if (c < '0' || c > '9') return false;
      v = v * 10 + (c - '0');
    }
    out = v;
    return true;
  }

  void routes() {
    server.route("/", [](const HttpRequest&) { return HttpReply{200, "text/html; charset=utf-8", embeddedWebPageHtml(), {}}; });
    server.route("/api/status", [this](const HttpRequest& req) { return jsonReply(200, status(req.remote)); });
    server.route("/api/cycles", [this](const HttpRequest& req) {
      int n = 50;
      if (!req.param("n").empty() && !parseInt(req.param("n"), n)) return errorReply(400, "n: expected a count");
      n = std::clamp(n, 0, static_cast<int>(kRecentCycles));
      std::string body = "[";
      for (std::size_t i = 0; i < recent.size() && i < static_cast<std::size_t>(n); ++i) body += (i ? "," : "") + recent[i];
      return HttpReply{200, kJsonType, body + "]\n", {}};
    });
    server.route("/api/archive", [this](const HttpRequest& req) {
      if (!src.archive) return errorReply(404, "no image archive (the cell config has no 'archive' section)");
      int n = 100;
      if (!req.param("n").empty() && !parseInt(req.param("n"), n)) return errorReply(400, "n: expected a count");
      json list = json::array();
      for (const auto& f : src.archive->list(static_cast<std::size_t>(std::clamp(n, 0, 1000))))
        list.push_back({{"name", f.stem + ".png"}, {"bytes", f.bytes}});
      return jsonReply(200, list);
    });
    server.routeAsync("/api/live.jpg", [this](const HttpRequest&, HttpRespond respond) {
      {
        std::lock_guard lock(mutex);
        if (live_.jpeg && renderedSeq == liveSeq) {
          respond(jpegReply(live_));
          return;
        }
      }
      request({"", std::move(respond)});
    });
    server.routeAsync("/api/archive.jpg", [this](const HttpRequest& req, HttpRespond respond) {
      const std::string name = req.param("name");
      if (!isArchiveName(name, ".png")) {
        respond(errorReply(400, "name: expected an archived frame's file name, e.g. 20261202-101530.123-c17.png"));
        return;
      }
      request({name, std::move(respond)});
    });
    server.routePost("/api/trigger", [this](const HttpRequest& req) {
      return action(req, "trigger", [&]() {
        int job = 0;
        if (!req.param("job").empty() && !parseInt(req.param("job"), job)) return errorReply(400, "job: expected a job id");
        if (job != 0 && src.cell->findJob(job) == nullptr) return errorReply(400, fmt::format("job {} is not configured", job));
        const int ran = job != 0 ? job : (src.defaultJob ? src.defaultJob() : 0);
        const std::uint32_t id = src.trigger ? src.trigger(job) : 0;
        if (id == 0) return errorReply(503, "BUSY_OVERRUN: the cycle queue is full");
        log::info("web", "operator trigger from {}: cycle {} (job {})", req.remote, id, ran);
        return jsonReply(200, json{{"cycle", id}, {"job", ran}});
      });
    });
    server.routePost("/api/job", [this](const HttpRequest& req) {
      return action(req, "job switch", [&]() {
        int job = 0;
        if (!parseInt(req.param("id"), job) || job == 0) return errorReply(400, "id: expected a job id");
        if (!src.setDefaultJob) return errorReply(500, "no job switch");
        if (auto r = src.setDefaultJob(job); !r) return errorReply(400, r.error().message);
        log::info("web", "operator from {}: default job {}", req.remote, job);
        return jsonReply(200, json{{"default_job", job}});
      });
    });
    server.routePost("/api/repeatability", [this](const HttpRequest& req) { return recordRepeatability(req); });
    server.websocket("/ws", [this] {
      json st = status("");
      st["type"] = "status";
      return st.dump();
    });
  }
};

WebPage::WebPage(boost::asio::io_context& io, WebServer& server, const config::WebConfig& web, WebPageSources sources)
    : impl_(std::make_unique<Impl>(io, server, web, std::move(sources))) {}

WebPage::~WebPage() { stop(); }

void WebPage::addStatusSection(const std::string& name, StatusSection fill) { impl_->sections[name] = std::move(fill); }

void WebPage::start() {
  Impl& s = *impl_;
  for (const auto& job : s.src.cell->jobs) s.overlayJobs[job.id] = overlayJobFor(job);
  const auto& c = s.src.cell->calibration;
  if (c.enabled) {
    if (!c.multiHeight.empty()) s.calib.push_back(readCalibFile("multiheight", c.multiHeight));
    for (const auto& [role, path] : {std::pair{"intrinsics", &c.intrinsics}, std::pair{"handeye", &c.handeye}, std::pair{"plane", &c.plane}})
      if (!path->empty()) s.calib.push_back(readCalibFile(role, *path));
  }
  s.repeatPath = repeatabilityRecordPath(s.src.cell->journalPath);
  if (auto r = readRepeatabilityRecord(s.repeatPath); !r) {
    s.repeatError = r.error().message;
    log::warn("web", "the last repeatability run is not shown: {}", s.repeatError);
  } else {
    s.repeat = std::move(*r);
  }
  s.routes();
  s.stopping = false;
  s.renderThread = std::thread([&s] { s.renderLoop(); });
}

void WebPage::stop() {
  Impl& s = *impl_;
  {
    std::lock_guard lock(s.mutex);
    s.stopping = true;
  }
  s.cv.notify_all();
  if (s.renderThread.joinable()) s.renderThread.join();
}

void WebPage::frameDone(const CycleResult& r, const CycleImage& image) {
  Impl& s = *impl_;
  int w = 0;
  {
    std::lock_guard lock(s.mutex);
    while (w == s.latest || w == s.busy) ++w;  // three slots: one is neither
  }
  Impl::LiveSlot& slot = s.live[static_cast<std::size_t>(w)];
  if (image.image.empty())
    slot.image.release();
  else
    image.image.copyTo(slot.image);  // no allocation once the slot has held a frame of this size and type
  slot.depth = image.depth;
  slot.intrinsics = image.intrinsics;
  slot.baseFromCamera = image.baseFromCamera;
  slot.result = r;
  {
    std::lock_guard lock(s.mutex);
    s.latest = w;
    ++s.liveSeq;
  }
  s.cv.notify_one();
  boost::asio::post(s.io, [&s, r] { s.onCycle(r); });
}

}  // namespace vgr::daemon
