// The journal records what started each cycle (docs/journal.md "trigger"): the PLC over
// Modbus, a robot's TRIG request (docs/protocols.md), or the operator (SIGUSR1 to vgrd).
// The real vgrd and camera emulator; a libmodbus client as the PLC and a raw TCP client as
// the UR robot; a robot's cycle is answered to the robot, not to the PLC.
#include <signal.h>

#include <regex>

#include "modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

class trigger_source : public ModbusCell {};

TEST_F(trigger_source, journal_names_modbus_robot_and_operator) {
  ASSERT_NO_FATAL_FAILURE(startCell());

  // The PLC.
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  const auto plc = triggerCounter(ctx, 4000, 5s);
  ASSERT_TRUE(plc.status & 0x08) << "RESULT_VALID";
  EXPECT_EQ(plc.error, 0);

  // The robot: TRIG,1 answers with the cycle it started.
  vgr::test::RawTcpClient robot(kUrPort);
  ASSERT_TRUE(robot.send("TRIG,1\n"));
  const std::string reply = robot.readUntil(')', 3s).value_or("");
  std::smatch m;
  ASSERT_TRUE(std::regex_match(reply, m, std::regex(R"(\(0,(\d+)(,-?\d+\.\d{6}){6}\))"))) << reply;
  const auto robotCycle = static_cast<std::uint32_t>(std::stoul(m[1].str()));
  EXPECT_NE(robotCycle, plc.resultId);
  // The PLC's registers still hold its own result (RESULT_ID unchanged).
  std::uint16_t head[4] = {};
  ASSERT_EQ(modbus_read_input_registers(ctx, 16, 4, head), 4);
  EXPECT_EQ(head[3], plc.resultId) << "RESULT_ID";
  modbus_close(ctx);
  modbus_free(ctx);

  // The operator. The robot's cycle reaches the journal just after its reply (robots are
  // answered first): wait for its line, or it would count as the operator's.
  ASSERT_FALSE(journalEntry(robotCycle).is_null());
  const std::size_t before = journal().size();
  ASSERT_EQ(::kill(vgrd_->pid(), SIGUSR1), 0);
  nlohmann::json op;
  for (int i = 0; i < 300 && op.is_null(); ++i) {
    const auto lines = journal();
    if (lines.size() > before) op = lines.back();
    else std::this_thread::sleep_for(10ms);
  }
  ASSERT_FALSE(op.is_null()) << log("vgrd.log");

  const nlohmann::json p = journalEntry(plc.resultId), r = journalEntry(robotCycle);
  ASSERT_FALSE(p.is_null());
  ASSERT_FALSE(r.is_null());
  EXPECT_EQ(p["trigger"], "modbus");
  EXPECT_EQ(r["trigger"], "robot");
  EXPECT_EQ(op["trigger"], "operator");
  EXPECT_EQ(r["status"], 0);
  EXPECT_EQ(op["status"], 0);
}

}  // namespace
