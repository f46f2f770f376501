#include "tools/vgr/cameras.hpp"

#include <cstdio>

#include <CLI/CLI.hpp>

#include "drivers/aravis_camera.hpp"

namespace vgr::tools {

int runCameras(const CamerasOptions& o) {
  const auto list = drivers::discoverCameras();
  if (o.json) {
    std::printf("[");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const auto& d = list[i];
      std::printf("%s{\"serial\":\"%s\",\"model\":\"%s\",\"vendor\":\"%s\",\"address\":\"%s\",\"id\":\"%s\",\"protocol\":\"%s\"}",
                  i ? "," : "", d.serial.c_str(), d.model.c_str(), d.vendor.c_str(), d.address.c_str(), d.id.c_str(),
                  d.protocol.c_str());
    }
    std::printf("]\n");
    return 0;
  }
  if (list.empty()) {
    std::printf("no cameras found\n");
    return 0;
  }
  std::printf("%-20s %-20s %-16s %-16s %s\n", "SERIAL", "MODEL", "VENDOR", "ADDRESS", "ID");
  for (const auto& d : list)
    std::printf("%-20s %-20s %-16s %-16s %s\n", d.serial.c_str(), d.model.c_str(), d.vendor.c_str(), d.address.c_str(), d.id.c_str());
  return 0;
}

CLI::App* CamerasCommand::add(CLI::App& parent) {
  auto* camerasCmd = parent.add_subcommand("cameras", "list the cameras discovery finds (serial, model, address)");
  camerasCmd->add_flag("--json", options_.json, "one JSON array");
  return camerasCmd;
}

}  // namespace vgr::tools
