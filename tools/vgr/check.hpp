// `vgr check --config FILE`: validates a cell config with the function `vgrd --check` uses
// (daemon/check.hpp). Prints "FILE: ok" (exit 0) or the loader's one line naming file, line
// and key on stderr (exit 2).
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CheckOptions {
  std::string configPath;
};

int runCheck(const CheckOptions& options);

class CheckCommand final : public OptionsSubcommand<CheckOptions, runCheck> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
