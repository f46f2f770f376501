// A cell job's locator, built as vgrd builds it at start (CycleRunner::prepareJobs) and as
// `vgrd --check` / `vgr check` build it to validate (daemon/check.hpp): a job with a folder
// gets its method (the cell entry's `method` override, else job.yaml's) from job.yaml and the
// template image (vision::makeLocator); an untaught job the blob-moments locator with its
// cell-config keys. Any thread; reads the job folder's files.
#pragma once

#include <memory>

#include "config/cell_config.hpp"
#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::daemon {

// Errors name the job and its folder: "job 1 (FOLDER): hu: unknown parameter 'x' (FILE:LINE: ...)",
// "FOLDER/template.png: cannot read the template image", or the job.yaml loader's line.
Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobConfig& job);

}  // namespace vgr::daemon
