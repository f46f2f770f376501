// Did a robot get exactly the parts its part order says (paper 002's sorting strategies,
// docs/demo.md "Sorting")? Checked against the renderer's truth: the camera emulator's
// truth.jsonl (each served frame's parts with their labels), vgrd's journal (which frame each
// cycle saw, and its parts best first) and the robot's replies in the order it got them.
// Used by vgr-sim-robot (--check-order) and the tests. Pure logic plus two file readers.
//
// Per cycle of the journal (status OK or NO_PART_FOUND) the robot must have got:
//   - every truth part of the frame that its order serves (label_only: those with its label;
//     the others: all), each once, with the truth part's label; a reply is paired with the
//     nearest truth part within kMatchMm (parts lie far apart);
//   - nothing else (no part the truth does not have: clutter served as a part is "extra");
//   - in the order's sequence: best_score and label_only the journal's order (best first),
//     by_label ascending labels (journal order within a label), random any order;
//   - for a cycle without any part it serves: one reply NO_PART_FOUND (1).
// A cycle the robot never got an answer for is "unseen".
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "config/cell_config.hpp"  // PartOrder
#include "core/result.hpp"
#include "sim/cell_scenes.hpp"     // CellPartTruth

namespace vgr::sim {

inline constexpr double kMatchMm = 10.0;  // a reply within this of a truth part is that part

// One reply as the robot read it.
struct RobotGot {
  int status = 0;
  std::uint32_t cycle = 0;
  double xMm = 0, yMm = 0;
  int label = 0;
  double confidence = 0;
};

// One journal line: the frame the cycle saw and its parts (best first).
struct JournalCycle {
  int status = 0;
  std::uint64_t frameId = 0;
  struct Part {
    double xMm = 0, yMm = 0;
    int label = 0;
  };
  std::vector<Part> parts;
};

struct SortCheck {
  int cycles = 0;          // journal cycles checked
  int unseen = 0;          // of them, cycles the robot got no reply of
  int expected = 0;        // truth parts the order serves, over the cycles seen
  int delivered = 0;       // OK replies
  int missed = 0;          // expected parts never delivered
  int wrongLabel = 0;      // delivered with another label than the truth part's (or not the order's label)
  int extra = 0;           // delivered parts that are no truth part
  int duplicates = 0;      // a truth part delivered twice
  int outOfOrder = 0;      // replies that break the order's sequence
  int missingNoPart = 0;   // cycles without a part to serve that got no NO_PART_FOUND reply
  double maxPosErrMm = 0;  // delivered part vs its truth part
  std::string firstProblem;  // the first problem found, for the log ("" when ok)
  bool ok() const {
    return cycles > 0 && unseen == 0 && missed == 0 && wrongLabel == 0 && extra == 0 && duplicates == 0 &&
           outOfOrder == 0 && missingNoPart == 0;
  }
};

SortCheck checkSorting(config::PartOrder order, int label, const std::map<std::uint64_t, std::vector<CellPartTruth>>& truth,
                       const std::map<std::uint32_t, JournalCycle>& journal, const std::vector<RobotGot>& got);

// truth.jsonl of vgr-sim-camera --truth (CellScenes::truthJson lines) by frame id.
Result<std::map<std::uint64_t, std::vector<CellPartTruth>>> readTruthFile(const std::string& path);
// vgrd's journal (docs/journal.md) by cycle id; only lines of `job` (0 = any).
Result<std::map<std::uint32_t, JournalCycle>> readJournalFile(const std::string& path, int job);

// "best_score", "by_label", "label_only", "random".
const char* partOrderName(config::PartOrder order);

}  // namespace vgr::sim
