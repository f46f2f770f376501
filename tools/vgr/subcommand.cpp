#include "tools/vgr/subcommand.hpp"

#include <cstdio>

namespace vgr::tools {

int badInput(const std::string& message) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return 2;
}

}  // namespace vgr::tools
