#include "vision/classify/classifying_locator.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/classify/part_features.hpp"

namespace vgr::vision::classify {
namespace {

class ClassifyingLocator final : public Locator {
 public:
  ClassifyingLocator(std::unique_ptr<Locator> inner, PartClassifier classifier, const ClassifyParams& params)
      : inner_(std::move(inner)), classifier_(std::move(classifier)), params_(params) {}

  std::string_view method() const override { return inner_->method(); }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    auto out = inner_->locate(gray);
    if (!out || out->parts.empty()) return out;
    auto blobs = segmentParts(gray, params_.threshold, params_.minAreaPx);
    if (!blobs) return std::unexpected(blobs.error());
    std::vector<Detection> kept;
    for (Detection& d : out->parts) {
      d.label = 0;
      d.confidence = 0;
      if (const PartBlob* b = nearestBlob(*blobs, d)) {
        const Prediction p = classifier_.predict(b->features, params_.minConfidence, params_.maxFeatureZ);
        d.label = p.label;
        d.confidence = p.confidence;
      }
      if (d.label > 0 || params_.keepUnknown) kept.push_back(d);
    }
    out->parts = std::move(kept);
    return out;
  }

 private:
  static const PartBlob* nearestBlob(const std::vector<PartBlob>& blobs, const Detection& d) {
    const PartBlob* best = nullptr;
    double bestD = std::numeric_limits<double>::max();
    for (const auto& b : blobs) {
      const double dist = std::hypot(b.cx - d.u, b.cy - d.v);
      const double radius = std::sqrt(b.areaPx / M_PI);
      if (dist <= radius && dist < bestD) best = &b, bestD = dist;
    }
    return best;
  }

  std::unique_ptr<Locator> inner_;
  PartClassifier classifier_;
  ClassifyParams params_;
};

}  // namespace

std::unique_ptr<Locator> makeClassifyingLocator(std::unique_ptr<Locator> inner, PartClassifier classifier,
                                                const ClassifyParams& params) {
  return std::make_unique<ClassifyingLocator>(std::move(inner), std::move(classifier), params);
}

}  // namespace vgr::vision::classify
