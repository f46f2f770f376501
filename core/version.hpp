// The version of this build: `git describe --tags --always --dirty` at build time
// ("0.1.0-gf659ba9-dirty" without a tag), or the project version outside a git checkout.
// Generated into the build folder by cmake/VgrVersion.cmake and linked only into the
// programs (library vgr_version): a test that needs it links vgr_version. Any thread.
#pragma once

namespace vgr {

const char* buildVersion();

}  // namespace vgr
