// Paper 003's recognition model as a small GG-CNN-style network (docs/grasp.md "Network"),
// run by OpenCV's dnn module from an ONNX file (opset 11; no Python at run time).
//
// The network (models/grasp/train_ggcnn.py builds and trains it): input 1 x 1 x H x W, the
// normalised height map of vision/grasp/grasp_input.hpp (H, W multiples of 12); output
// 1 x 4 x H x W: grasp quality, cos 2 theta, sin 2 theta and opening / kNetWidthScalePx per
// pixel (paper 003 Sec. 4.2: "grasping quality, grasping angle, and grasping width", the
// same size as the input).
// Detection (GG-CNN's post-processing): the quality map smoothed (Gaussian, sigma 1 px),
// its local maxima at or above minQuality best first, at least 5 network px apart, refined
// to sub-pixel by a parabola through the neighbours; at each the angle is
// 0.5 atan2(sin, cos) and the opening the width map's value, both from the smoothed maps.
// Peaks without a valid depth within 2 px, or wider than the gripper opens, are dropped.
// Threads: one at a time (cv::dnn::Net::forward is not re-entrant).
#pragma once

#include <memory>
#include <string>

#include "vision/grasp/grasp_detector.hpp"

namespace vgr::vision::grasp {

// Errors (Status::BadArgument, naming the file): "PATH: no such file", "PATH: cannot load
// the grasp network: <OpenCV's reason>", "PATH: not a grasp network: <the output it gave>".
Result<std::unique_ptr<GraspDetector>> makeGgcnnDetector(const GraspDetectorOptions& options);

}  // namespace vgr::vision::grasp
