#include "vision/locate/input_check.hpp"

#include <string>

#include <fmt/core.h>

namespace vgr::vision {
namespace {

class InputCheckedLocator final : public Locator {
 public:
  InputCheckedLocator(std::unique_ptr<Locator> method, cv::Size templateSize, PixelRect roi)
      : method_(std::move(method)), templateSize_(templateSize), roi_(roi) {}

  std::string_view method() const override { return method_->method(); }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    const std::string_view name = method_->method();
    if (gray.empty() || gray.type() != CV_8UC1)
      return fail(Status::BadArgument,
                  fmt::format("{}: expected a non-empty 8-bit gray image, got {}", name,
                              gray.empty() ? std::string("an empty image")
                                           : fmt::format("a {}x{} px image of {} channel(s), depth {}", gray.cols, gray.rows,
                                                         gray.channels(), gray.depth())));
    cv::Rect area(0, 0, gray.cols, gray.rows);
    if (!roi_.empty()) {
      area &= cv::Rect(roi_.x, roi_.y, roi_.width, roi_.height);
      if (area.empty())
        return fail(Status::BadArgument, fmt::format("{}: the search ROI {},{} {}x{} lies outside the {}x{} px image "
                                                     "(job.yaml 'roi' is in live image px)",
                                                     name, roi_.x, roi_.y, roi_.width, roi_.height, gray.cols, gray.rows));
    }
    if (gray.cols < templateSize_.width && gray.rows < templateSize_.height)
      return fail(Status::BadArgument, fmt::format("{}: the {}x{} px image is smaller than the {}x{} px template", name,
                                                   gray.cols, gray.rows, templateSize_.width, templateSize_.height));
    if (area.width < templateSize_.width && area.height < templateSize_.height)
      return fail(Status::BadArgument,
                  fmt::format("{}: the search ROI {},{} {}x{} (clipped to the {}x{} px image: {}x{} px) is smaller than the "
                              "{}x{} px template",
                              name, roi_.x, roi_.y, roi_.width, roi_.height, gray.cols, gray.rows, area.width, area.height,
                              templateSize_.width, templateSize_.height));
    return method_->locate(gray);
  }

 private:
  std::unique_ptr<Locator> method_;
  cv::Size templateSize_;
  PixelRect roi_;
};

}  // namespace

std::unique_ptr<Locator> withInputChecks(std::unique_ptr<Locator> method, cv::Size templateSize, PixelRect searchRoi) {
  return std::make_unique<InputCheckedLocator>(std::move(method), templateSize, searchRoi);
}

}  // namespace vgr::vision
