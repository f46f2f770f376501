// libFuzzer target: job files (config::parseJob, docs/localization.md "Jobs"), the
// job.yaml a `vgr teach` wrote or an integrator edited, and the template image header it
// names (PNG, JPEG or BMP, read for its size). Input: byte 0 = n, the next n bytes are
// written as the image file `fuzzimg` in the job folder, the rest is the YAML text (the
// seeds name `template: fuzzimg`). Checks: no crash, leak or UB; every failure is
// BadArgument in the documented form "SOURCE:LINE: ..."; every success satisfies the
// ranges the locators rely on.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "config/job.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

const std::string& folder() {
  static const std::string dir = [] {
    const auto d = std::filesystem::temp_directory_path() / ("vgr-fuzz-job-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    // A 64 x 48 PNG header (signature + IHDR) as template.png: enough for the size check.
    const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                 0,    0,   0,   64,  0,    0,    0,    48,  8, 0, 0, 0,  0,   0,   0,   0};
    std::ofstream(d / "template.png", std::ios::binary).write(reinterpret_cast<const char*>(png), sizeof png);
    return d.string();
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::size_t n = std::min<std::size_t>(data[0], size - 1);
  {
    std::ofstream img(folder() + "/fuzzimg", std::ios::binary | std::ios::trunc);
    img.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(n));
  }
  const std::string text(reinterpret_cast<const char*>(data + 1 + n), size - 1 - n);
  const auto job = vgr::config::parseJob(text, "fuzz/job.yaml", folder());
  if (!job) {
    check(job.error().code == vgr::Status::BadArgument);
    check(job.error().message.rfind("fuzz/job.yaml:", 0) == 0);
    return 0;
  }
  check(job->partHeightMm >= 0 && job->partHeightMm <= 1000);
  check(std::isfinite(job->referenceXMm) && std::isfinite(job->referenceYMm) && std::isfinite(job->referenceRzDeg));
  const auto& t = job->taught;
  check(t.minScore >= 0 && t.minScore <= 1);
  check(t.maxParts >= 1 && t.maxParts <= 64);
  for (const auto& g : job->grasps) check(std::isfinite(g.u) && std::isfinite(g.v));
  for (const auto& r : t.regions) {
    check(r.polygon.size() >= 3);
    check(r.heightFactor >= 0 && r.heightFactor <= 1);
  }
  return 0;
}
