// The Modbus server of the real vgrd, with the camera emulator, driven by third-party PLCs:
// mbpoll (level handshake), pymodbus under /usr/bin/python3 (counter mode; overrun,
// clear-error and a deadline expiry while the camera hangs), checked against the journal.
#include <signal.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

using CmdResult = vgr::test::CommandResult;

CmdResult run(const std::string& cmd) { return vgr::test::runCommand(cmd + " 2>&1"); }

std::string mbpoll(const std::string& args) { return "mbpoll -m tcp -p 1502 -a 1 -0 " + args; }

// "[16]: \t9" or "[17]: \t65532 (-4)" -> the signed value of each line, in order.
std::vector<double> mbpollValues(const std::string& out) {
  std::vector<double> v;
  static const std::regex re(R"(\[(\d+)\]:\s+(\S+)(?:\s+\((-?\d+)\))?)");
  std::istringstream in(out);
  for (std::string l; std::getline(in, l);) {
    std::smatch m;
    if (std::regex_search(l, m, re)) v.push_back(std::stod(m[3].matched ? m[3].str() : m[2].str()));
  }
  return v;
}

int mbpollStatus() {
  const auto r = run(mbpoll("-r 16 -c 1 -t 3 -1 127.0.0.1"));
  const auto v = mbpollValues(r.out);
  return r.exitCode == 0 && v.size() == 1 ? static_cast<int>(v[0]) : -1;
}

nlohmann::json runPython(const std::filesystem::path& dir, const std::string& script, const std::string& args = "") {
  const auto path = dir / "plc.py";
  std::ofstream(path) << script;
  const auto r = run("/usr/bin/python3 " + path.string() + " " + args);
  // The JSON object is the last line.
  std::string last;
  std::istringstream in(r.out);
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) last = l;
  auto j = nlohmann::json::parse(last, nullptr, false);
  if (r.exitCode != 0 || !j.is_object()) {
    ADD_FAILURE() << "pymodbus PLC failed (exit " << r.exitCode << "):\n" << r.out;
    return nlohmann::json::object();
  }
  return j;
}

constexpr const char* kPyPrelude = R"PY(
import json, sys, time
from pymodbus.client import ModbusTcpClient
from pymodbus.payload import BinaryPayloadDecoder
from pymodbus.constants import Endian
c = ModbusTcpClient("127.0.0.1", port=1502)
assert c.connect()
def signed(v): return v - 65536 if v >= 32768 else v
def ir(a, n):
    rr = c.read_input_registers(a, n, slave=1)
    if rr.isError(): raise SystemExit("FC04 failed: %s" % rr)
    return rr.registers
def w(a, v):
    rq = c.write_register(a, v, slave=1)
    if rq.isError(): raise SystemExit("FC06 failed: %s" % rq)
def wait(pred, what, timeout=5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s = ir(16, 1)[0]
        if pred(s): return s
        time.sleep(0.001)
    raise SystemExit("timeout waiting for " + what)
)PY";

using modbus_vgrd = ModbusCell;

TEST_F(modbus_vgrd, LevelHandshakeWithMbpoll) {
  ASSERT_NO_FATAL_FAILURE(startCell());
  ASSERT_EQ(run(mbpoll("-r 1 -t 4 127.0.0.1 1")).exitCode, 0);  // JOB_ID 1
  const auto t = run(mbpoll("-r 0 -t 4 127.0.0.1 1"));          // TRIGGER
  ASSERT_EQ(t.exitCode, 0) << t.out;
  int s = 0;
  const auto t0 = Clock::now();
  while (((s = mbpollStatus()) & 0x02) == 0 && Clock::now() - t0 < 2s) {
  }
  ASSERT_NE(s & 0x02, 0) << "TRIGGER_ACK, status " << s;
  ASSERT_EQ(run(mbpoll("-r 0 -t 4 127.0.0.1 0")).exitCode, 0);  // drop TRIGGER
  while (((s = mbpollStatus()) & 0x08) == 0 && Clock::now() - t0 < 3s) {
  }
  ASSERT_NE(s & 0x08, 0) << "RESULT_VALID, status " << s;
  EXPECT_EQ(s & (0x02 | 0x04), 0) << "no ACK, not BUSY";
  EXPECT_NE(s & 0x10, 0) << "PART_FOUND";

  const auto head = mbpollValues(run(mbpoll("-r 16 -c 6 -t 3 -1 127.0.0.1")).out);
  ASSERT_EQ(head.size(), 6u);
  EXPECT_EQ(head[1], 0) << "ERROR_CODE";
  EXPECT_EQ(head[2], head[3]) << "RESULT_ID = ACQ_ID";
  EXPECT_EQ(head[4], 1) << "NUM_FOUND";
  const auto floats = mbpollValues(run(mbpoll("-r 24 -c 6 -t 3:float -B -1 127.0.0.1")).out);
  const auto ints = mbpollValues(run(mbpoll("-r 40 -c 6 -t 3 -1 127.0.0.1")).out);
  ASSERT_EQ(floats.size(), 6u);
  ASSERT_EQ(ints.size(), 6u);
  EXPECT_NEAR(floats[0] * 10, ints[0], 0.51) << "X and its int16 mirror (0.1 mm)";
  EXPECT_NEAR(floats[5] * 100, ints[5], 0.51) << "R3 and its int16 mirror (0.01 deg)";

  // The journal has the same cycle and pose.
  const auto id = static_cast<std::uint32_t>(head[3]);
  nlohmann::json entry;
  for (int i = 0; i < 200 && entry.is_null(); ++i) {
    for (const auto& j : journal())
      if (j["cycle"].get<std::uint32_t>() == id) entry = j;
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_FALSE(entry.is_null()) << "cycle " << id << " not in the journal";

  ASSERT_EQ(run(mbpoll("-r 0 -t 4 127.0.0.1 2")).exitCode, 0);  // RESULT_ACK
  EXPECT_EQ(mbpollStatus() & 0x18, 0) << "RESULT_VALID and PART_FOUND cleared";
}

TEST_F(modbus_vgrd, CounterModeWithPymodbus) {
  ASSERT_NO_FATAL_FAILURE(startCell());
  const auto out = runPython(dir_, std::string(kPyPrelude) + R"PY(
wait(lambda s: s & 1 and not s & 4, "READY")
res = []
for n in range(1, 6):
    w(2, 1000 + n)                        # TRIGGER_ID: each new value triggers
    acq = ir(18, 1)[0]
    s = wait(lambda s: s & 0x08 and not s & 0x04, "RESULT_VALID")
    r = ir(16, 6)
    res.append({"acq": acq, "result_id": r[3], "code": signed(r[1]), "found": r[4], "status": r[0]})
print(json.dumps({"results": res}))
)PY");
  ASSERT_TRUE(out.contains("results")) << out.dump();
  std::set<int> ids;
  for (const auto& r : out["results"]) {
    EXPECT_EQ(r["acq"], r["result_id"]) << r.dump();
    EXPECT_EQ(r["code"].get<int>(), 0) << r.dump();
    EXPECT_EQ(r["found"].get<int>(), 1) << r.dump();
    EXPECT_EQ(r["status"].get<int>() & 0x02, 0) << "counter-mode ACK cleared with the result";
    ids.insert(r["result_id"].get<int>());
  }
  EXPECT_EQ(ids.size(), 5u);
  // The journal is written after the PLC was served: give it a moment.
  std::set<int> journaled;
  for (int i = 0; i < 200 && journaled.size() < 5; ++i) {
    journaled.clear();
    for (const auto& j : journal()) journaled.insert(j["cycle"].get<int>());
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_EQ(journaled, ids);
}

// The camera hangs (SIGSTOP): the trigger still ends in RESULT_VALID with -4 CAMERA_ERROR
// within cell.cycle_deadline_ms; a second trigger meanwhile is an overrun (-3 at once);
// CLEAR_ERROR clears ERROR and OVERRUN; after SIGCONT the cell recovers.
TEST_F(modbus_vgrd, DeadlineExpiryOverrunAndClearErrorWithPymodbus) {
  ASSERT_NO_FATAL_FAILURE(startCell());
  ASSERT_EQ(::kill(camera_->pid(), SIGSTOP), 0);
  const auto out = runPython(dir_, std::string(kPyPrelude) + R"PY(
wait(lambda s: s & 1 and not s & 4, "READY")
w(1, 1)
t0 = time.monotonic()
w(0, 1); wait(lambda s: s & 2, "TRIGGER_ACK"); w(0, 0)
w(0, 1)                                   # again, while BUSY
ov = ir(16, 2)
w(0, 0)
s = wait(lambda s: s & 0x08, "RESULT_VALID", timeout=10)
ms = (time.monotonic() - t0) * 1000.0
r = ir(16, 4)
w(0, 0x02 | 0x04)                         # RESULT_ACK + CLEAR_ERROR
cl = ir(16, 2)
w(0, 0)
print(json.dumps({"overrun_status": ov[0], "overrun_code": signed(ov[1]), "ms": ms, "status": r[0],
                  "code": signed(r[1]), "acq": r[2], "result_id": r[3], "cleared_status": cl[0], "cleared_code": signed(cl[1])}))
)PY");
  ::kill(camera_->pid(), SIGCONT);
  ASSERT_TRUE(out.contains("code")) << out.dump() << log("vgrd.log");
  EXPECT_NE(out["overrun_status"].get<int>() & 0x80, 0) << "OVERRUN";
  EXPECT_NE(out["overrun_status"].get<int>() & 0x04, 0) << "still BUSY";
  EXPECT_EQ(out["overrun_code"].get<int>(), -3);
  EXPECT_EQ(out["code"].get<int>(), -4) << "CAMERA_ERROR";
  EXPECT_NE(out["status"].get<int>() & 0x20, 0) << "ERROR";
  EXPECT_EQ(out["acq"], out["result_id"]);
  // Answered by the deadline (1500 ms in the sim cell), plus polling slack; not early either.
  EXPECT_LT(out["ms"].get<double>(), cfg_.cycleDeadlineMs + 250.0);
  EXPECT_GT(out["ms"].get<double>(), cfg_.cycleDeadlineMs - 400.0);
  EXPECT_EQ(out["cleared_status"].get<int>() & (0x20 | 0x80 | 0x08), 0);
  EXPECT_EQ(out["cleared_code"].get<int>(), 0);

  // Recovery: within 20 s a counter trigger gets a part again.
  const auto rec = runPython(dir_, std::string(kPyPrelude) + R"PY(
end = time.monotonic() + 20
n = 0
while time.monotonic() < end:
    n += 1
    w(2, n)
    wait(lambda s: s & 0x08 and not s & 0x04, "RESULT_VALID", timeout=5)
    r = ir(16, 2)
    if signed(r[1]) == 0: break
    time.sleep(0.2)
print(json.dumps({"code": signed(r[1]), "tries": n}))
)PY");
  EXPECT_EQ(rec.value("code", -99), 0) << rec.dump() << log("vgrd.log");
}

}  // namespace
