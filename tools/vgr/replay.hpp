// `vgr replay --journal J --archive A --job DIR [--config CELL]`: runs a (changed) job on the
// frames vgrd archived (daemon/image_archive.hpp) and reports, frame by frame and in sum,
// what the cell would now deliver differently from what it did: the regression check before
// a job change goes live (docs/commissioning.md "Replay").
//
// For every journal line with an "archive" file (of the job being replayed): the PNG is the
// 8-bit image vgrd's locator saw; the job's locator (daemon::makeJobLocator, as vgrd builds
// it) runs on it, and the detections are mapped exactly as vgrd maps them: the cell config's
// mapping (daemon::makeCellMapping: calibration files, multi-height map or `model`), the
// job's grasp height and reference (job.yaml) and the cell job's angle_offset_deg, through
// vision::partPoses. A frame differs when its status, its number of parts, a part's label
// or a part's pose (x, y, z beyond --tol-mm; rz, ry, rx beyond --tol-deg, in order) differ
// from its journal line. Frames whose file is gone (deleted for the quota) are counted as
// missing, not compared.
//
// Output: one line per differing frame (--all: every frame) and a summary line; --json: one
// JSON object (frames, summary). A progress bar on stderr when it is a terminal (or
// --progress). Exit code 0 when no frame differs, 1 when some do, 2 on bad input.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct ReplayOptions {
  std::string journal, archive, job;
  std::string config;   // cell config; default: the job's `calibration`
  int jobId = 0;        // journal job id to replay; 0 = the cell job whose folder is --job (else every job)
  double tolMm = 0.002;   // the journal keeps 3 decimals: 0.0005 of rounding each side
  double tolDeg = 0.002;
  bool json = false, all = false, progress = false;
};

int runReplay(const ReplayOptions& o);

class ReplayCommand final : public OptionsSubcommand<ReplayOptions, runReplay> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
