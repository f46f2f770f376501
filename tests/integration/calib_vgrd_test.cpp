// vgrd with a `calibration` section whose files are missing: it starts, and a PLC-triggered
// cycle is answered with -6 NOT_CALIBRATED; the log names the file and why.

#include <regex>
#include <sstream>

#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

std::string run(const std::string& cmd, int* rc = nullptr) {
  const auto r = vgr::test::runCommand(cmd + " 2>&1");
  if (rc) *rc = r.exitCode;
  return r.out;
}

std::string mbpoll(const std::string& args) { return "mbpoll -m tcp -p 1502 -a 1 -0 " + args; }

std::vector<int> values(const std::string& out) {
  std::vector<int> v;
  static const std::regex re(R"(\[(\d+)\]:\s+(\S+)(?:\s+\((-?\d+)\))?)");
  std::istringstream in(out);
  for (std::string l; std::getline(in, l);) {
    std::smatch m;
    if (std::regex_search(l, m, re)) v.push_back(std::stoi(m[3].matched ? m[3].str() : m[2].str()));
  }
  return v;
}

class calib_vgrd : public ModbusCell {};

TEST_F(calib_vgrd, missing_calibration_file_gives_not_calibrated) {
  ASSERT_NO_FATAL_FAILURE(startCell([](std::string yaml) {
    // The example's calibration section, pointed at files that are not there.
    for (auto at = yaml.find("sim-calib/"); at != std::string::npos; at = yaml.find("sim-calib/"))
      yaml.replace(at, 10, "missing-calib/");
    return yaml;
  }));
  int rc = -1;
  run(mbpoll("-r 1 -t 4 127.0.0.1 1"), &rc);  // JOB_ID 1
  ASSERT_EQ(rc, 0);
  run(mbpoll("-r 0 -t 4 127.0.0.1 1"), &rc);  // TRIGGER
  ASSERT_EQ(rc, 0);
  int s = 0;
  const auto t0 = Clock::now();
  while (Clock::now() - t0 < 3s) {
    const auto v = values(run(mbpoll("-r 16 -c 1 -t 3 -1 127.0.0.1")));
    s = v.size() == 1 ? v[0] : 0;
    if (s & 0x02) break;  // TRIGGER_ACK
  }
  run(mbpoll("-r 0 -t 4 127.0.0.1 0"));  // drop TRIGGER
  std::vector<int> head;
  while (Clock::now() - t0 < 4s) {
    head = values(run(mbpoll("-r 16 -c 2 -t 3 -1 127.0.0.1")));
    if (head.size() == 2 && (head[0] & 0x08)) break;  // RESULT_VALID
  }
  ASSERT_EQ(head.size(), 2u);
  EXPECT_NE(head[0] & 0x08, 0) << "RESULT_VALID";
  EXPECT_EQ(head[1], -6) << "ERROR_CODE NOT_CALIBRATED";
  const std::string l = log("vgrd.log");
  EXPECT_NE(l.find("NOT_CALIBRATED"), std::string::npos) << l;
  EXPECT_NE(l.find("intrinsics.yaml: no such intrinsics file"), std::string::npos) << l;
}

}  // namespace
