// The commissioning page's JSON endpoints and images over real HTTP (daemon/web_page.hpp,
// docs/commissioning.md); the browser drives the page itself in web_page_browser_test.
//   - /api/status: READY, the job, the camera's counters, the three calibration files of the
//     sim cell with the residuals they carry and their age, the archive, sections;
//   - /api/cycles: exactly the journal's lines, newest first;
//   - /api/live.jpg: a JPEG of the last cycle with its grasp point's magenta disc at the
//     journal's u_px, v_px; /api/archive + /api/archive.jpg for archived cycles, names
//     checked (no path gets through);
//   - operator actions: 403 while web.actions is off; with it on, from an allowed address
//     with the header, a trigger runs the job asked for and a job switch changes the
//     default job (JOB_ID 0 then runs it); wrong methods 405, unknown paths 404.
#include <opencv2/imgcodecs.hpp>

#include "modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

struct Reply {
  int status = 0;
  std::string head, body;
};

Reply http(int port, const std::string& method, const std::string& target, const std::string& headers = "") {
  const std::string r = vgr::test::httpRequest(static_cast<std::uint16_t>(port), method, target, 5000ms, headers);
  Reply out;
  const auto p = r.find("\r\n\r\n");
  out.head = r.substr(0, p);
  if (p != std::string::npos) out.body = r.substr(p + 4);
  if (r.size() > 12) out.status = std::stoi(r.substr(9, 3));
  return out;
}

std::string header(const Reply& r, const std::string& name) {
  const auto at = r.head.find("\r\n" + name + ": ");
  if (at == std::string::npos) return "";
  const auto from = at + name.size() + 4;
  return r.head.substr(from, r.head.find("\r\n", from) - from);
}

// Two jobs: the sim cell's plate job 1 and a copy of it as job 2.
std::string twoJobs(std::string yaml) {
  const auto b = yaml.find("\n# Used by the simulators");
  return yaml.insert(b, "  - id: 2\n    name: plate-copy\n    method: moments\n    min_area_px: 2000\n    max_area_px: 200000\n");
}

class web_page_vgrd : public ModbusCell {};

TEST_F(web_page_vgrd, StatusCyclesImagesAndArchiveOverHttpActionsOff) {
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  ASSERT_NO_FATAL_FAILURE(startCell([port](std::string yaml) {
    return yaml + "\nweb:\n  bind: 127.0.0.1\n  port: " + std::to_string(port) + "\narchive:\n  every_nth_good: 2\n  quota_mb: 50\n";
  }));
  std::vector<std::uint32_t> cycles;
  ASSERT_NO_FATAL_FAILURE(triggerCycles(4, 10, 5s, cycles));
  ASSERT_FALSE(journalEntry(cycles.back()).is_null());

  const Reply page = http(port, "GET", "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(header(page, "Content-Type").find("text/html"), std::string::npos);
  EXPECT_NE(page.body.find("<title>vgrd commissioning</title>"), std::string::npos);

  const auto st = nlohmann::json::parse(http(port, "GET", "/api/status").body, nullptr, false);
  ASSERT_TRUE(st.is_object());
  EXPECT_EQ(st["cell"], "sim-cell");
  EXPECT_EQ(st["ready"], true);
  EXPECT_EQ(st["default_job"], 1);
  EXPECT_EQ(st["web"]["actions"], false);
  EXPECT_EQ(st["web"]["client"], "127.0.0.1");
  ASSERT_EQ(st["jobs"].size(), 1u);
  EXPECT_EQ(st["jobs"][0]["id"], 1);
  EXPECT_EQ(st["camera"]["streaming"], true);
  EXPECT_GE(st["camera"]["frames"].get<int>(), 4);
  EXPECT_EQ(st["cycles"]["total"], 4);
  EXPECT_EQ(st["cycles"]["last"], journalEntry(cycles.back()));
  EXPECT_EQ(st["stages_ms"]["total"]["n"], 4);
  ASSERT_EQ(st["calibration"].size(), 3u) << st["calibration"].dump();
  for (const auto& c : st["calibration"]) {
    EXPECT_FALSE(c["residuals"].empty()) << c.dump();
    EXPECT_GE(c["age_s"].get<double>(), 0) << c.dump();
    EXPECT_EQ(c["changed_since_start"], false);
  }
  EXPECT_NEAR(st["calibration"][0]["residuals"]["rms_px"].get<double>(), 0.0718, 1e-3) << "intrinsics.yaml's rms_px";
  EXPECT_TRUE(st["sections"].is_object());
  EXPECT_EQ(st["archive"]["written"].get<int>() + st["archive"]["queued"].get<int>(), 2) << "every 2nd OK cycle";
  // The archive writes behind the cycles (a niced thread): wait for both frames.
  for (auto until = Clock::now() + 20s; Clock::now() < until;) {
    const auto a = nlohmann::json::parse(http(port, "GET", "/api/status").body, nullptr, false);
    if (a.is_object() && a["archive"]["written"] == 2) break;
    std::this_thread::sleep_for(50ms);
  }

  // /api/cycles: the journal's lines, newest first.
  const auto list = nlohmann::json::parse(http(port, "GET", "/api/cycles?n=10").body, nullptr, false);
  ASSERT_TRUE(list.is_array());
  const auto lines = journal();
  ASSERT_EQ(list.size(), lines.size());
  for (std::size_t i = 0; i < list.size(); ++i) EXPECT_EQ(list[i], lines[lines.size() - 1 - i]);
  EXPECT_EQ(http(port, "GET", "/api/cycles?n=x").status, 400);

  // The live image: the last cycle, its grasp point drawn where the journal says.
  const Reply live = http(port, "GET", "/api/live.jpg");
  ASSERT_EQ(live.status, 200) << live.head << live.body;
  EXPECT_EQ(header(live, "Content-Type"), "image/jpeg");
  EXPECT_EQ(header(live, "X-Vgr-Cycle"), std::to_string(cycles.back()));
  const cv::Mat jpeg = cv::imdecode(std::vector<uchar>(live.body.begin(), live.body.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(jpeg.cols, 1280);
  ASSERT_EQ(jpeg.rows, 1024);
  const auto last = journalEntry(cycles.back());
  ASSERT_EQ(last["status"], 0);
  const cv::Vec3b px = jpeg.at<cv::Vec3b>(static_cast<int>(std::lround(last["parts"][0]["v_px"].get<double>())),
                                          static_cast<int>(std::lround(last["parts"][0]["u_px"].get<double>())));
  EXPECT_TRUE(px[0] > 180 && px[1] < 90 && px[2] > 180) << "BGR " << px;

  // The archive: what the journal names, as JPEGs with their overlay; names are checked.
  const auto archived = nlohmann::json::parse(http(port, "GET", "/api/archive").body, nullptr, false);
  ASSERT_TRUE(archived.is_array());
  std::vector<std::string> named;
  for (const auto& l : lines)
    if (l.contains("archive")) named.push_back(l["archive"]);
  ASSERT_EQ(archived.size(), named.size());
  for (std::size_t i = 0; i < named.size(); ++i) EXPECT_EQ(archived[i]["name"], named[named.size() - 1 - i]);
  const Reply a = http(port, "GET", "/api/archive.jpg?name=" + named.front());
  EXPECT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(header(a, "Content-Type"), "image/jpeg");
  EXPECT_EQ(http(port, "GET", "/api/archive.jpg?name=../journal.jsonl").status, 400);
  EXPECT_EQ(http(port, "GET", "/api/archive.jpg?name=20200101-000000.000-c1.png").status, 404);

  // Actions are off: refused whoever asks; wrong methods and paths.
  EXPECT_EQ(http(port, "POST", "/api/trigger", "X-Vgr-Action: 1\r\n").status, 403);
  EXPECT_EQ(http(port, "POST", "/api/job?id=1", "X-Vgr-Action: 1\r\n").status, 403);
  const Reply get = http(port, "GET", "/api/trigger");
  EXPECT_EQ(get.status, 405);
  EXPECT_EQ(header(get, "Allow"), "POST");
  EXPECT_EQ(http(port, "POST", "/api/status").status, 405);
  EXPECT_EQ(http(port, "GET", "/api/nothing").status, 404);
  EXPECT_EQ(journal().size(), 4u) << "no cycle from a refused action";
}

TEST_F(web_page_vgrd, OperatorTriggersAJobAndSwitchesTheDefaultJobFromAnAllowedAddress) {
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  ASSERT_NO_FATAL_FAILURE(startCell([port](std::string yaml) {
    return twoJobs(yaml) + "\nweb:\n  bind: 127.0.0.1\n  port: " + std::to_string(port) +
           "\n  actions: true\n  allowed_clients: [127.0.0.1]\n";
  }));
  // Without the header (what another site's page could send): refused.
  EXPECT_EQ(http(port, "POST", "/api/trigger?job=2").status, 403);
  // A job that is not configured: 400, nothing runs.
  EXPECT_EQ(http(port, "POST", "/api/trigger?job=9", "X-Vgr-Action: 1\r\n").status, 400);
  EXPECT_EQ(http(port, "POST", "/api/job?id=9", "X-Vgr-Action: 1\r\n").status, 400);

  const Reply t = http(port, "POST", "/api/trigger?job=2", "X-Vgr-Action: 1\r\n");
  ASSERT_EQ(t.status, 200) << t.body;
  const auto tj = nlohmann::json::parse(t.body);
  EXPECT_EQ(tj["job"], 2);
  const auto entry = journalEntry(tj["cycle"].get<std::uint32_t>());
  ASSERT_FALSE(entry.is_null());
  EXPECT_EQ(entry["trigger"], "operator");
  EXPECT_EQ(entry["job"], 2);

  // Switch the default job: a PLC writing JOB_ID 0 now runs job 2.
  const Reply s = http(port, "POST", "/api/job?id=2", "X-Vgr-Action: 1\r\n");
  ASSERT_EQ(s.status, 200) << s.body;
  EXPECT_EQ(nlohmann::json::parse(http(port, "GET", "/api/status").body)["default_job"], 2);
  std::vector<std::uint32_t> cycles;
  ASSERT_NO_FATAL_FAILURE(triggerCycles(1, 40, 5s, cycles));
  EXPECT_EQ(journalEntry(cycles.back())["job"], 2);
  EXPECT_NE(log("vgrd.log").find("default job 1 -> 2"), std::string::npos) << log("vgrd.log");
}

}  // namespace
