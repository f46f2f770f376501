// Running a program to completion from a test: a shell command line (/bin/sh -c, so
// redirections such as "2>&1" and pipes work as with popen), its stdout and stderr captured
// separately, its exit code, killed (SIGKILL to its process group) when it outlives the
// timeout. Blocking; call from any thread.
#pragma once

#include <chrono>
#include <string>

namespace vgr::test {

struct CommandResult {
  int exitCode = -1;  // -1 when it did not exit normally (signal, timeout, could not start)
  std::string out;    // stdout
  std::string err;    // stderr
  bool timedOut = false;
};

CommandResult runCommand(const std::string& shellCommand,
                         std::chrono::milliseconds timeout = std::chrono::milliseconds(240000));

// Our `vgr` tool with `args` (a shell word list), stdout and stderr merged into `out`.
CommandResult runVgr(const std::string& args);

// The last non-empty line of `text` (a tool's final JSON line).
std::string lastLine(const std::string& text);

// Path of one of our built executables (VGR_BIN_DIR/<name>), and of a source file
// (VGR_SOURCE_DIR/<relative>).
std::string binPath(const std::string& name);
std::string sourcePath(const std::string& relative);

}  // namespace vgr::test
