// Modbus client mode (protocol/modbus_client_trigger.hpp) end to end: vgrd is the Modbus
// CLIENT of a PLC that cannot write. The PLC is a real Modbus TCP server — vgr-sim-plc
// --serve (libmodbus) or pymodbus' server under /usr/bin/python3 — holding the laser sensor
// bit; vgrd polls it, triggers on the debounced rising edge, runs the cycle with the camera
// emulator and writes the 30-word result block into the PLC's holding registers 100..129.
#include <unistd.h>

#include <fstream>
#include <set>
#include <thread>

#include "tests/support/modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

// A loopback port nobody listens on now (the kernel's pick), for the PLC's server, so this
// test does not depend on the sim cell's 1503 being free on a shared machine.
int freePort() { return vgr::test::freeLoopbackPort(); }

const int kPlcPort = freePort();

// The sim cell's modbus.client section, enabled and pointed at kPlcPort.
std::string enableClient(std::string yaml) {
  const std::string from = "  client:\n    enabled: false\n    host: 127.0.0.1\n    port: 1503";
  const auto at = yaml.find(from);
  EXPECT_NE(at, std::string::npos) << "sim-cell.yaml has no disabled modbus.client section on 1503";
  if (at != std::string::npos)
    yaml.replace(at, from.size(), "  client:\n    enabled: true\n    host: 127.0.0.1\n    port: " + std::to_string(kPlcPort));
  return yaml;
}

class modbus_client_mode : public ModbusCell {
 protected:
  // The journal entry of the cycle whose low 16 bits are `resultId` (as the PLC sees it).
  std::optional<nlohmann::json> journalFor(int resultId) {
    for (int i = 0; i < 200; ++i) {
      for (const auto& j : journal())
        if ((j["cycle"].get<std::uint32_t>() & 0xFFFFu) == static_cast<std::uint32_t>(resultId)) return j;
      std::this_thread::sleep_for(10ms);
    }
    return std::nullopt;
  }

  // Every PLC line must be a found part whose floats match the journal's pose of that cycle.
  void expectResultsMatchJournal(const std::vector<nlohmann::json>& results, std::size_t expected) {
    ASSERT_EQ(results.size(), expected);
    std::set<int> ids;
    for (const auto& r : results) {
      ASSERT_TRUE(r.contains("result_id")) << r.dump() << log("vgrd.log");
      EXPECT_EQ(r["status"].get<int>(), 0) << r.dump();
      EXPECT_EQ(r["num_found"].get<int>(), 1) << r.dump();
      ids.insert(r["result_id"].get<int>());
      const auto j = journalFor(r["result_id"].get<int>());
      ASSERT_TRUE(j.has_value()) << "no journal line for " << r.dump();
      EXPECT_EQ((*j)["trigger"], "modbus");
      ASSERT_EQ((*j)["parts"].size(), 1u);
      // float32 in the PLC (~6e-5 mm at 500 mm), journal rounded to 0.001 mm.
      EXPECT_NEAR(r["x"].get<double>(), (*j)["parts"][0]["x_mm"].get<double>(), 1e-3) << r.dump();
      EXPECT_NEAR(r["y"].get<double>(), (*j)["parts"][0]["y_mm"].get<double>(), 1e-3) << r.dump();
      EXPECT_NEAR(r["r3"].get<double>(), (*j)["parts"][0]["rz_deg"].get<double>(), 1e-3) << r.dump();
    }
    EXPECT_EQ(ids.size(), expected) << "every sensor pulse is a new result";
  }
};

TEST_F(modbus_client_mode, SimPlcServerPulsesTheSensorAndReceivesEveryResult) {
  ASSERT_NE(kPlcPort, 0);
  ASSERT_NO_FATAL_FAILURE(startCell(enableClient));
  auto plc = vgr::test::ChildProcess::spawn({bin("vgr-sim-plc"), "--serve", "--port", std::to_string(kPlcPort),
                                                "--cycles", "6", "--interval-ms", "50", "--json"},
                                               (dir_ / "plc.log").string());
  ASSERT_TRUE(plc.has_value());
  ASSERT_TRUE(plc->waitForLine("listening", 3s));
  std::vector<nlohmann::json> results;
  for (int i = 0; i < 6; ++i) {
    const auto line = plc->readLine(10s);
    ASSERT_TRUE(line.has_value()) << log("vgrd.log");
    results.push_back(nlohmann::json::parse(*line));
  }
  EXPECT_EQ(plc->wait(5s), 0);
  ASSERT_NO_FATAL_FAILURE(expectResultsMatchJournal(results, 6));
}

TEST_F(modbus_client_mode, AGlitchShorterThanTheDebounceTriggersNothing) {
  ASSERT_NE(kPlcPort, 0);
  ASSERT_NO_FATAL_FAILURE(startCell(enableClient));  // debounce_ms: 20
  auto plc = vgr::test::ChildProcess::spawn({bin("vgr-sim-plc"), "--serve", "--port", std::to_string(kPlcPort),
                                                "--cycles", "1", "--pulse-ms", "4", "--timeout-ms", "1500", "--json"},
                                               (dir_ / "plc.log").string());
  ASSERT_TRUE(plc.has_value());
  ASSERT_TRUE(plc->waitForLine("listening", 3s));
  const auto cycle = plc->readLine(10s);
  ASSERT_TRUE(cycle.has_value()) << log("vgrd.log");
  const auto j = nlohmann::json::parse(*cycle);
  EXPECT_EQ(j["status"], "timeout") << j.dump();
  EXPECT_EQ(j["step"], "result_valid") << j.dump();
  EXPECT_TRUE(journal().empty()) << "a 4 ms glitch must not trigger a cycle";
}

// pymodbus as the PLC: its own server, the sensor on discrete input 0, the block read from
// its datastore. Three pulses, each answered by a new result.
TEST_F(modbus_client_mode, PymodbusServerAsThePlc) {
  ASSERT_NE(kPlcPort, 0);
  // dir_ exists only once the cell starts, and the PLC must be up first.
  const auto tmp = std::filesystem::temp_directory_path();
  const auto script = tmp / ("vgr-plc-server-" + std::to_string(::getpid()) + ".py");
  const auto plcLog = tmp / ("vgr-plc-server-" + std::to_string(::getpid()) + ".log");
  std::ofstream(script) << R"PY(
import asyncio, json, struct, sys, time
PORT = int(sys.argv[1])
from pymodbus.server import StartAsyncTcpServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusSlaveContext, ModbusServerContext

store = ModbusSlaveContext(di=ModbusSequentialDataBlock(0, [0] * 16), co=ModbusSequentialDataBlock(0, [0] * 16),
                           hr=ModbusSequentialDataBlock(0, [0] * 200), ir=ModbusSequentialDataBlock(0, [0] * 16),
                           zero_mode=True)
ctx = ModbusServerContext(slaves=store, single=True)

def block():
    return store.getValues(3, 100, 30)   # registers 16..45 of vgrd's map

def f32(b, reg):                         # high word first (modbus.float_word_order)
    i = reg - 16
    return struct.unpack(">f", struct.pack(">HH", b[i], b[i + 1]))[0]

async def until(pred, timeout=10.0):
    t = time.monotonic() + timeout
    while time.monotonic() < t:
        if pred(block()):
            return True
        await asyncio.sleep(0.002)
    return False

async def plc():
    print(json.dumps({"listening": PORT}), flush=True)
    if not await until(lambda b: b[0] & 1 and not b[0] & 4, 20.0):
        print(json.dumps({"error": "never READY"}), flush=True); return
    last = block()[3]
    for n in range(1, 4):
        store.setValues(2, 0, [1])       # laser sensor on
        await asyncio.sleep(0.1)
        store.setValues(2, 0, [0])
        if not await until(lambda b: b[0] & 8 and b[3] != last):
            print(json.dumps({"n": n, "status": "timeout"}), flush=True); return
        b = block()
        last = b[3]
        code = b[1] - 65536 if b[1] >= 32768 else b[1]
        print(json.dumps({"n": n, "result_id": b[3], "status": code, "num_found": b[4],
                          "x": f32(b, 24), "y": f32(b, 26), "r3": f32(b, 34)}), flush=True)
        await asyncio.sleep(0.05)

async def main():
    asyncio.create_task(StartAsyncTcpServer(context=ctx, address=("127.0.0.1", PORT)))
    await plc()

asyncio.run(main())
)PY";
  auto plc = vgr::test::ChildProcess::spawn({"/usr/bin/python3", script.string(), std::to_string(kPlcPort)}, plcLog.string());
  ASSERT_TRUE(plc.has_value());
  ASSERT_TRUE(plc->waitForLine("listening", 10s));
  ASSERT_NO_FATAL_FAILURE(startCell(enableClient));
  std::vector<nlohmann::json> results;
  for (int i = 0; i < 3; ++i) {
    const auto line = plc->readLine(30s);
    ASSERT_TRUE(line.has_value()) << log("vgrd.log");
    results.push_back(nlohmann::json::parse(*line));
  }
  EXPECT_EQ(plc->wait(5s), 0) << "the script ends after its three cycles";
  std::filesystem::remove(script);
  std::filesystem::remove(plcLog);
  ASSERT_NO_FATAL_FAILURE(expectResultsMatchJournal(results, 3));
}

}  // namespace
