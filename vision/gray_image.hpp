// One conversion from camera samples to the 8-bit gray every locator works on, for vgrd's
// cycle (daemon/cycle_runner.cpp) and for the offline tools reading saved frames (vgr locate,
// eval, teach, calibrate). Pure image code, any thread.
//
// Mono10/12/16 frames arrive LSB-aligned: a 16-bit sample holding `bitDepth` significant
// bits (0..2^bitDepth - 1). The 8-bit image keeps the top 8 significant bits, rounded to
// nearest: v / 2^(bitDepth - 8).
//
// Saved frames (`vgr grab --save`) are PNGs scaled to the full 16-bit range (MSB-aligned:
// v * 2^(16 - bitDepth)), PNG's own convention for samples of fewer bits (its sBIT chunk,
// which cv::imwrite cannot write): any viewer shows them right, and read back as 16 bits
// they convert to exactly the 8-bit image vgrd locates in.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::vision {

// samples: CV_16UC1 with bitDepth in [9, 16] significant bits, or CV_8UC1 (bitDepth 8,
// copied by reference). gray8: CV_8UC1, reused when its size fits.
void toGray8(const cv::Mat& samples, int bitDepth, cv::Mat& gray8);

// LSB-aligned samples (bitDepth significant bits) as full-range 16-bit, for saving.
cv::Mat toFullRange16(const cv::Mat& samples, int bitDepth);

// An image file as 8-bit gray: an 8-bit file as it is (colour converted to gray), a 16-bit
// one as full-range samples (toGray8 with bitDepth 16). Errors name the file: "PATH: cannot
// read the image"; a 16-bit image with every sample below 4096 (LSB-aligned Mono10/12, which
// full-range reading would turn black) is refused with the reason.
Result<cv::Mat> readGray8(const std::string& path);

}  // namespace vgr::vision
