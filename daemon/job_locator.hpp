// The Locator a job describes, built the one way vgrd (CycleRunner::prepareJobs),
// `vgrd --check` / `vgr check` (daemon/check.hpp), `vgr locate` and `vgr eval` build it:
//   - a job folder: the template image read from the job (vision::readGray8), the method
//     (job.yaml `method`, or an override) built by vision::makeLocator, and, when job.yaml
//     has a `classify:` section, wrapped in the part classifier
//     (vision/classify/classifying_locator.hpp, paper 002) so every detection carries a
//     label and its confidence;
//   - a cell job without a folder: the blob-moments locator with its cell-config keys;
//   - a 3D job folder (`kind: 3d`, config/job3d.hpp): makeJobLocator3d below, the model cloud
//     and search parameters given to vision::cloud::makeLocator3d (paper 004; Open3D stays
//     inside vision/cloud, this header is plain).
// Start-up code, any one thread; reads the job folder's files.
#pragma once

#include <memory>
#include <string_view>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "config/job3d.hpp"
#include "core/result.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/locate/locator.hpp"
#include "vision/overlay.hpp"

namespace vgr::daemon {

// method empty = the job's own method. Errors: Status::BadArgument, naming the file at fault.
Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobFile& job, std::string_view method = {});

// A cell config's job. Errors name the job and its folder: "job 1 (FOLDER): hu: unknown
// parameter 'x' (FILE:LINE: ...)", "FOLDER/template.png: cannot read the template image", or
// the job.yaml loader's line; a 3D job (job.depth) is refused (it has makeJobLocator3d).
Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobConfig& job);

// A cell config's 3D job (job.depth): FOLDER/job.yaml (loadJob3d) and its model.ply, the
// locator built (the model's features computed: seconds for a dense model). Errors
// (Status::BadArgument) name the job and the file: "job 3 (FOLDER): FOLDER/model.ply: ...".
Result<std::unique_ptr<vision::cloud::Locator3d>> makeJobLocator3d(const config::JobConfig& job);
// A 3D job folder already loaded (`vgr locate`): its model.ply read and the locator built.
// Errors (Status::BadArgument) name the file: "FOLDER/model.ply: ...".
Result<std::unique_ptr<vision::cloud::Locator3d>> makeJobLocator3d(const config::Job3dFile& job);

// What the overlay picture (vision/overlay.hpp) draws of a job: its search ROI, and its
// template's size and grasp point (the found part's outline). A job without a folder has
// neither (an empty OverlayJob). Reads the template image; start-up code, any one thread.
vision::OverlayJob overlayJobFor(const config::JobFile& job);
vision::OverlayJob overlayJobFor(const config::JobConfig& job);

}  // namespace vgr::daemon
