#include "daemon/job_locator.hpp"

#include <string>

#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "config/job3d.hpp"
#include "vision/classify/classifying_locator.hpp"
#include "vision/classify/part_classifier.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/moments_locator.hpp"
#include "vision/ply_file.hpp"

namespace vgr::daemon {

Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobFile& job, std::string_view method) {
  auto read = vision::readGray8(job.templatePath());
  if (!read) return fail(Status::BadArgument, "the template image: " + read.error().message);
  const cv::Mat templ = *read;
  auto locator = vision::makeLocator(method.empty() ? std::string_view(job.method) : method, templ, job.taught);
  if (!locator || job.classify.model.empty()) return locator;
  auto classifier = vision::classify::PartClassifier::load(job.classifierPath());
  if (!classifier) return std::unexpected(classifier.error());
  vision::classify::ClassifyParams params;
  params.minConfidence = job.classify.minConfidence;
  params.maxFeatureZ = job.classify.maxFeatureZ;
  params.threshold = job.classify.threshold;
  params.keepUnknown = job.classify.keepUnknown;
  return vision::classify::makeClassifyingLocator(std::move(*locator), std::move(*classifier), params);
}

Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobConfig& job) {
  if (job.depth)
    return fail(Status::BadArgument, fmt::format("job {} ({}) is a 3D job (kind: 3d): it locates in depth frames, not "
                                                 "in gray images",
                                                 job.id, job.folder));
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
  auto loc = makeJobLocator(*jf, job.method);
  if (!loc) return fail(loc.error().code, fmt::format("job {} ({}): {}", job.id, job.folder, loc.error().message));
  return std::move(*loc);
}

Result<std::unique_ptr<vision::cloud::Locator3d>> makeJobLocator3d(const config::Job3dFile& job) {
  auto model = vision::readPlyCloud(job.modelPath());
  if (!model) return fail(Status::BadArgument, model.error().message);
  auto loc = vision::cloud::makeLocator3d(*model, job.grasp, job.search);
  if (!loc) return fail(Status::BadArgument, fmt::format("{}: {}", job.modelPath(), loc.error().message));
  return std::move(*loc);
}

Result<std::unique_ptr<vision::cloud::Locator3d>> makeJobLocator3d(const config::JobConfig& job) {
  auto why = [&](const Error& e) { return fail(Status::BadArgument, fmt::format("job {} ({}): {}", job.id, job.folder, e.message)); };
  auto jf = config::loadJob3d(job.folder);
  if (!jf) return why(jf.error());
  auto loc = makeJobLocator3d(*jf);
  if (!loc) return why(loc.error());
  return std::move(*loc);
}

vision::OverlayJob overlayJobFor(const config::JobFile& job) {
  vision::OverlayJob o;
  o.searchRoi = job.taught.searchRoi;
  o.templateGrasp = job.taught.grasp;
  const cv::Mat templ = vision::readGray8(job.templatePath()).value_or(cv::Mat());
  o.templateWidth = templ.cols;
  o.templateHeight = templ.rows;
  return o;
}

vision::OverlayJob overlayJobFor(const config::JobConfig& job) {
  if (job.folder.empty() || job.depth) return {};
  auto jf = config::loadJob(job.folder);
  return jf ? overlayJobFor(*jf) : vision::OverlayJob{};
}

}  // namespace vgr::daemon
