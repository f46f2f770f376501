#include "daemon/job_locator.hpp"

#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "config/job.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/moments_locator.hpp"

namespace vgr::daemon {

Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobConfig& job) {
  if (job.folder.empty()) {
    // Untaught: the blob-moments method with the job's keys in the cell config.
    vision::MomentsParams params;
    params.threshold = job.threshold;
    params.minAreaPx = job.minAreaPx;
    params.maxAreaPx = job.maxAreaPx;
    return vision::makeUntaughtMomentsLocator(params);
  }
  auto jf = config::loadJob(job.folder);
  if (!jf) return std::unexpected(jf.error());
  const cv::Mat templ = vision::readGray8(jf->templatePath()).value_or(cv::Mat());
  if (templ.empty()) return fail(Status::BadArgument, jf->templatePath() + ": cannot read the template image");
  auto loc = vision::makeLocator(job.method, templ, jf->taught);
  if (!loc) return fail(loc.error().code, fmt::format("job {} ({}): {}", job.id, job.folder, loc.error().message));
  return std::move(*loc);
}

}  // namespace vgr::daemon
