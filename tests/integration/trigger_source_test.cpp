// The journal records what started each cycle (docs/journal.md "trigger"): the PLC over
// Modbus, a robot's TRIG request (docs/protocols.md), or the operator (SIGUSR1 to vgrd).
// The real vgrd and camera emulator; a libmodbus client as the PLC and a raw TCP client as
// the UR robot; a robot's cycle is answered to the robot, not to the PLC.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <regex>

#include "modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

// One request line to 127.0.0.1:port, its reply up to ')' (the ur dialect), or "" on timeout.
std::string askUr(int port, const std::string& request, std::chrono::milliseconds timeout) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(request.size())) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (reply.find(')') == std::string::npos && std::chrono::steady_clock::now() < until) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char buf[256];
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      reply.append(buf, static_cast<std::size_t>(n));
    }
  }
  ::close(fd);
  return reply;
}

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
  const std::string reply = askUr(kUrPort, "TRIG,1\n", 3s);
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

  // The operator.
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
