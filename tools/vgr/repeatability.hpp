// `vgr repeatability`: N triggers of a part that does not move, and the spread of what the
// cell delivers: mean, standard deviation and max - min of x, y, z (mm) and rx, ry, rz (deg,
// Z-Y-X) in the robot base frame, the figure integrators take before sign-off
// (docs/commissioning.md, "Repeatability").
//   live (default): plays the PLC against the running vgrd of --config: N counter-mode
//     triggers over Modbus TCP (docs/protocols.md), each result read from the registers
//     the PLC reads (float32 X..R3) once RESULT_VALID comes with RESULT_ID = ACQ_ID;
//   --images GLOB: the cycle's locate + map steps in-process on recorded frames of the
//     still part (vgr grab --save), exactly as vgrd maps them.
// A live run's figures go to vgrd's commissioning page (POST /api/repeatability, kept beside
// the journal; --no-record: measure only); a cell without a page says so.
// Exit: 0 measured (and within --max-sigma-mm / --max-sigma-deg when given), 1 a shot
// found no part or ended in an error, or the spread is above the bar; 2 bad input.
#pragma once

#include <string>
#include <vector>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct RepeatabilityOptions {
  std::string config;               // the cell config (required)
  int shots = 30;                   // live: triggers, [2, 100000]
  int job = 0;                      // job id (0: the cell's first job)
  std::vector<std::string> images;  // replay: frames (files or globs) instead of live triggers
  int intervalMs = 0;               // live: pause between a result and the next trigger
  double maxSigmaMm = 0;            // > 0: exit 1 when sigma of x, y or z exceeds it
  double maxSigmaDeg = 0;           // > 0: exit 1 when sigma of an angle exceeds it
  bool json = false;
  bool record = true;               // live: post the figures to vgrd's page (daemon/repeatability_record.hpp)
};

int runRepeatability(const RepeatabilityOptions& o);

class RepeatabilityCommand final : public OptionsSubcommand<RepeatabilityOptions, runRepeatability> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
