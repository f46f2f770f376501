// `vgr journal-bench`: what the cycle journal (daemon/journal.hpp) costs the cycle thread
// per record under each fdatasync policy (every record, every 1000 ms, never), measured on
// the disk of --dir: wall and CPU time per append, p50 / p99 / max. Figures: docs/journal.md.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct JournalBenchOptions {
  int records = 2000;           // appends per policy
  int periodMs = 10;            // pause between appends (a cycle's pace; 0 = back to back)
  std::string dir = "/var/tmp"; // where the journal is written (the disk measured)
};

// Prints one JSON line per policy; 0, or 2 when the folder cannot be written.
int runJournalBench(const JournalBenchOptions& options);

class JournalBenchCommand final : public OptionsSubcommand<JournalBenchOptions, runJournalBench> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
