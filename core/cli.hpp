// The command-line conventions of every vgr program (vgr, vgrd, the simulators, the
// benches), in one place (docs/plant.md, "Exit codes"):
//   - `--help` shows every option's default value;
//   - exit codes: 0 done (also --help and --version), 1 nothing found or a check failed,
//     2 bad input — a command line CLI11 cannot parse included (CLI11's own codes, 105 to
//     127, would tell a script nothing it could act on).
// Header-only, for the main() of programs that already use CLI11.
#pragma once

#include <optional>

#include <CLI/CLI.hpp>

namespace vgr::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;    // nothing found, a failed check
inline constexpr int kExitBadInput = 2;  // a malformed command line, config or file

// Call before adding options (subcommands added later inherit it): --help prints defaults.
inline void showDefaults(CLI::App& app) { app.option_defaults()->always_capture_default(); }

// Parses; nullopt to go on, else the exit code to return now (--help/--version printed: 0;
// a parse error printed with its usage hint: 2).
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
}

}  // namespace vgr::cli
