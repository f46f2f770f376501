// The shape every `vgr` subcommand has (tools/vgr/<name>.hpp/.cpp, one file per
// subcommand, libcamera's src/apps/cam/ layout). A subcommand holds its options; main.cpp
// lists every subcommand in one table (STYLE.md rule 3), calls add() on each, parses the
// command line, then run() on the one selected. One thread.
//
// Each subcommand's header also declares its options struct and a free
// `int run<Name>(const <Name>Options&)`, so tests can run it in-process.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace vgr::tools {

class Subcommand {
 public:
  virtual ~Subcommand() = default;
  // Declares the subcommand and its options under `parent` (the top-level app, or a group
  // such as `calibrate`); the options bind to members of this object, which must outlive
  // the parse. Returns the new CLI::App (owned by `parent`).
  virtual CLI::App* add(CLI::App& parent) = 0;
  // After a parse that selected this subcommand: the process exit code.
  virtual int run() = 0;
};

// `message` and a newline on stderr; returns 2, the exit code for bad input.
int badInput(const std::string& message);

}  // namespace vgr::tools
