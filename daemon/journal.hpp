// The append-only cycle journal: one JSON object per line, per cycle (fields in
// docs/journal.md). Written from the cycle thread after the result was handed to the PLC
// and robots, so a slow disk never delays a reply.
#pragma once

#include <cstdio>
#include <string>

#include "core/cycle.hpp"
#include "core/result.hpp"

namespace vgr::daemon {

class Journal {
 public:
  Journal() = default;
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Creates the parent folder if needed; error names the path.
  Result<void> open(const std::string& path);
  void append(const CycleResult& r);
  // "trigger" is the cycle's TriggerSource ("modbus", "robot", "operator").
  static std::string toJson(const CycleResult& r);

 private:
  std::FILE* file_ = nullptr;
};

}  // namespace vgr::daemon
