// `vgr cameras` (docs/cameras.md): the cameras discovery finds on the network.
#pragma once

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CamerasOptions {
  bool json = false;  // one JSON array instead of a table
};

// Lists the cameras discovery finds (serial, model, address). Exit code 0.
int runCameras(const CamerasOptions& options);

class CamerasCommand final : public OptionsSubcommand<CamerasOptions, runCameras> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
