// libFuzzer target: the cell config parser (config::parseCellConfig), i.e. a YAML file an
// installer typed. Checks: no crash, leak or UB under ASan/UBSan; every failure is one
// line in the documented form "SOURCE:LINE: ..." (SOURCE = the name we pass); every
// success satisfies the validated ranges the rest of vgrd relies on.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>

#include "config/cell_config.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto cfg = vgr::config::parseCellConfig(text, "fuzz.yaml");
  if (!cfg) {
    const std::string& m = cfg.error().message;
    check(cfg.error().code == vgr::Status::BadArgument);
    check(m.rfind("fuzz.yaml:", 0) == 0);
    return 0;
  }
  check(!cfg->jobs.empty());
  std::set<int> ids;
  for (const auto& j : cfg->jobs) {
    check(j.id >= 1 && j.id <= 32767);
    check(j.maxAreaPx > j.minAreaPx);
    check(ids.insert(j.id).second);
  }
  check(cfg->cycleDeadlineMs >= 100 && cfg->cycleDeadlineMs <= 60000);
  check(cfg->camera.reconnectMaxMs >= cfg->camera.reconnectMinMs);
  check(cfg->model.camZ > cfg->model.planeZ);
  check(cfg->modbus.maxClients >= 1 && cfg->modbus.maxClients <= 64);
  check(cfg->modbus.client.statusAddress + 30 <= 65536);
  return 0;
}
