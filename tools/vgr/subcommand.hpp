// The shape every `vgr` subcommand has (tools/vgr/<name>.hpp/.cpp, one file per
// subcommand, libcamera's src/apps/cam/ layout). A subcommand holds its options; main.cpp
// lists every subcommand in one table (STYLE.md rule 3), calls add() on each, parses the
// command line, then run() on the one selected. One thread.
//
// Each subcommand's header declares its options struct, a free
// `int run<Name>(const <Name>Options&)` (tests run it in-process) and
// `class <Name>Command final : public OptionsSubcommand<<Name>Options, run<Name>>`.
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

// The usual subcommand: options in a struct, run by a free function that tests can call
// in-process. Subclasses write add() only.
template <class Options, int (*Run)(const Options&)>
class OptionsSubcommand : public Subcommand {
 public:
  int run() override { return Run(options_); }

 protected:
  Options options_;
};

// `message` and a newline on stderr; returns 2, the exit code for bad input.
int badInput(const std::string& message);

}  // namespace vgr::tools
