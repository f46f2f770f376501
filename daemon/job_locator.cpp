#include "daemon/job_locator.hpp"

#include <string>

#include <opencv2/imgcodecs.hpp>

#include "vision/classify/classifying_locator.hpp"
#include "vision/classify/part_classifier.hpp"

namespace vgr::daemon {

Result<std::unique_ptr<vision::Locator>> makeJobLocator(const config::JobFile& job, std::string_view method) {
  const cv::Mat templ = cv::imread(job.templatePath(), cv::IMREAD_GRAYSCALE);
  if (templ.empty()) return fail(Status::BadArgument, job.templatePath() + ": cannot read the template image");
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

}  // namespace vgr::daemon
