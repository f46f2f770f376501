// `vgr grasp detect` and `vgr grasp tensors` (docs/grasp.md):
//   detect   grasps in the depth images of a data set, one JSON line per image: each grasp
//            in px, in the camera frame and, with a calibration, in the robot base frame
//            (vision/grasp/grasp_pose.hpp: the 3D calibration --camera-pose when given, else
//            the plane calibration --intrinsics/--handeye/--plane with the depth at the
//            centre). Exit 0 when some image had a grasp, 1 when none had, 2 on bad input.
//   tensors  the grasp network's training data from a grasp data set: OUT/input.npy
//            (N x 1 x H x W float16, vision/grasp/grasp_input.hpp) and OUT/target.npy
//            (N x 4 x H x W float16: quality, cos 2 theta, sin 2 theta, width / 50 px), drawn
//            from grasps.csv as GG-CNN does (the middle third of each rectangle across), and
//            OUT/images.txt; read by models/grasp/train_ggcnn.py. Exit 0, or 2.
// Offline tool code, one thread.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"
#include "vision/grasp/grasp_detector.hpp"

namespace vgr::tools {

struct GraspDetectOptions {
  std::string dataset;
  std::string image;        // one image of the data set (e.g. images/0003.png); empty = all
  int limit = 0;            // first N images; 0 = all
  vision::grasp::GraspDetectorOptions detector;
  std::string cameraPose;   // 3D calibration: handeye.yaml of the fixed depth camera (X = T_base_cam)
  std::string intrinsics, handEye, plane;  // plane calibration (all three)
};
int runGraspDetect(const GraspDetectOptions& options);

class GraspDetectCommand final : public OptionsSubcommand<GraspDetectOptions, runGraspDetect> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

struct GraspTensorsOptions {
  std::string dataset;
  std::string out;
  int limit = 0;
};
int runGraspTensors(const GraspTensorsOptions& options);

class GraspTensorsCommand final : public OptionsSubcommand<GraspTensorsOptions, runGraspTensors> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
