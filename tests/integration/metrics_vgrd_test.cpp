// vgrd's Prometheus endpoint (docs/plant.md): the sim cell with a `web` section, N cycles
// triggered by a libmodbus PLC, then GET /metrics over TCP, parsed by a real parser
// (python3-prometheus-client's text_string_to_metric_families under /usr/bin/python3):
// vgr_cycles_total sums to N, the cycle histogram counts N, and the server stays read-only.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>

#include "modbus_cell.hpp"
#include "tests/support/command.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

std::string body(const std::string& response) {
  const auto p = response.find("\r\n\r\n");
  return p == std::string::npos ? "" : response.substr(p + 4);
}

// Parses the exposition with prometheus_client and prints the sums the test checks as JSON.
constexpr const char* kParser = R"PY(
import json, sys
from prometheus_client.parser import text_string_to_metric_families
fams = {f.name: f for f in text_string_to_metric_families(open(sys.argv[1]).read())}
def total(fam, sample, **labels):
    return sum(s.value for s in fams[fam].samples
               if s.name == sample and all(s.labels.get(k) == v for k, v in labels.items()))
out = {
  "types": {n: f.type for n, f in fams.items()},
  "cycles": total("vgr_cycles", "vgr_cycles_total"),
  "cycles_ok": total("vgr_cycles", "vgr_cycles_total", status="OK"),
  "cycle_count": total("vgr_cycle_seconds", "vgr_cycle_seconds_count"),
  "cycle_inf": total("vgr_cycle_seconds", "vgr_cycle_seconds_bucket", le="+Inf"),
  "grab_count": total("vgr_cycle_stage_seconds", "vgr_cycle_stage_seconds_count", stage="grab"),
  "locate_count": total("vgr_cycle_stage_seconds", "vgr_cycle_stage_seconds_count", stage="locate"),
  "modbus_triggers": total("vgr_triggers", "vgr_triggers_total", source="modbus"),
  "frames": total("vgr_camera_frames", "vgr_camera_frames_total"),
  "ready": total("vgr_ready", "vgr_ready"),
  "build_info": [s.labels for s in fams["vgr_build_info"].samples],
}
print(json.dumps(out))
)PY";

class metrics_vgrd : public ModbusCell {};

TEST_F(metrics_vgrd, cycles_total_and_histogram_count_equal_the_triggers) {
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  ASSERT_NO_FATAL_FAILURE(startCell([port](std::string yaml) {
    return yaml + "\nweb:\n  bind: 127.0.0.1\n  port: " + std::to_string(port) + "\n";
  }));

  constexpr int kCycles = 7;
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  for (int i = 1; i <= kCycles; ++i) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(100 + i), 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID, cycle " << i << "\n" << log("vgrd.log");
  }
  modbus_close(ctx);
  modbus_free(ctx);
  // The journal is written after the PLC got its result; the metrics before the PLC.
  ASSERT_FALSE(journalEntry(kCycles).is_null());

  const std::string response = vgr::test::httpRequest(port, "GET", "/metrics");
  ASSERT_NE(response.find("HTTP/1.1 200"), std::string::npos) << response;
  EXPECT_NE(response.find("Content-Type: text/plain; version=0.0.4"), std::string::npos) << response;
  const std::string text = body(response);
  const auto metricsFile = dir_ / "metrics.txt";
  std::ofstream(metricsFile) << text;
  const auto script = dir_ / "parse_metrics.py";
  std::ofstream(script) << kParser;
  const vgr::test::CommandResult parsed = vgr::test::runCommand("/usr/bin/python3 " + script.string() + " " + metricsFile.string());
  ASSERT_EQ(parsed.exitCode, 0) << parsed.out << parsed.err << "\n" << text;
  const auto j = nlohmann::json::parse(parsed.out, nullptr, false);
  ASSERT_TRUE(j.is_object()) << parsed.out;

  EXPECT_EQ(j["cycles"].get<double>(), kCycles) << text;
  EXPECT_EQ(j["cycle_count"].get<double>(), kCycles);
  EXPECT_EQ(j["cycle_inf"].get<double>(), kCycles);
  EXPECT_EQ(j["grab_count"].get<double>(), kCycles);
  EXPECT_EQ(j["locate_count"].get<double>(), kCycles);
  EXPECT_EQ(j["modbus_triggers"].get<double>(), kCycles);
  int ok = 0;
  for (const auto& e : journal()) ok += e["status"] == 0 ? 1 : 0;
  EXPECT_EQ(j["cycles_ok"].get<double>(), ok);
  EXPECT_GE(j["frames"].get<double>(), ok);
  EXPECT_EQ(j["ready"].get<double>(), 1);
  EXPECT_EQ(j["types"]["vgr_cycles"], "counter");
  EXPECT_EQ(j["types"]["vgr_cycle_seconds"], "histogram");
  EXPECT_EQ(j["types"]["vgr_camera_frames"], "counter");
  ASSERT_EQ(j["build_info"].size(), 1u);
  EXPECT_FALSE(j["build_info"][0]["version"].get<std::string>().empty());

  // Read-only and exact: HEAD has no body, other methods 405, other paths 404.
  const std::string head = vgr::test::httpRequest(port, "HEAD", "/metrics");
  EXPECT_NE(head.find("HTTP/1.1 200"), std::string::npos) << head;
  EXPECT_TRUE(body(head).empty());
  EXPECT_NE(vgr::test::httpRequest(port, "POST", "/metrics").find("HTTP/1.1 405"), std::string::npos);
  EXPECT_NE(vgr::test::httpRequest(port, "GET", "/nothing").find("HTTP/1.1 404"), std::string::npos);
}

}  // namespace
