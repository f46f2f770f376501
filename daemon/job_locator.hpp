// The Locator a job folder describes, built the one way vgrd (CycleRunner::prepareJobs),
// `vgr locate` and `vgr eval` build it: the template image read from the job, the method
// (job.yaml `method`, or an override) built by vision::makeLocator, and, when job.yaml has a
// `classify:` section, wrapped in the part classifier (vision/classify/classifying_locator.hpp,
// paper 002) so every detection carries a label and its confidence.
// Start-up code, one thread. Errors: Status::BadArgument, naming the file at fault.
#pragma once

#include <memory>
#include <string_view>

#include "config/job.hpp"
#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::daemon {

// method empty = the job's own method.
Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobFile& job, std::string_view method = {});

}  // namespace vgr::daemon
