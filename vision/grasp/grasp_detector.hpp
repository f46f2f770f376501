// Grasp detection in a depth image (docs/grasp.md): where a parallel-jaw gripper coming
// down along the camera's optical axis should close. A grasp is paper 003's
// G = (p, theta, w, q) (Sec. 4.2, eq. (12)): centre p, angle theta, opening w, quality q.
// Two detectors behind one interface, chosen by name from one table (makeGraspDetector):
//   ggcnn     paper 003's recognition model as a small GG-CNN-style network (quality,
//             cos 2 theta, sin 2 theta and width maps) run by OpenCV's dnn from an ONNX file
//             (vision/grasp/ggcnn_detector.hpp; trained by models/grasp/train_ggcnn.py)
//   analytic  the baseline: segment what stands above the floor, fit an oriented box to each
//             object, grip across its short side (vision/grasp/analytic_detector.hpp)
//
// Conventions (docs/architecture.md "Units"): image px, x right, y down, pixel centres at
// integers; the angle is the closing axis's, degrees counter-clockwise as displayed, in
// (-90, 90] (a parallel gripper is symmetric under 180 deg). Depth images CV_32FC1 z in mm,
// 0 = no data. Threads: a detector is built once and used by one thread at a time (cv::dnn
// nets are not re-entrant).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.hpp"
#include "vision/grasp/height_map.hpp"

namespace vgr::vision::grasp {

// The gripper the grasps are for (mm).
struct Gripper {
  double maxOpeningMm = 60;   // (0, 1000] widest opening: wider sections are not grasped
  double clearanceMm = 2;     // [0, 50] open jaw to the face it closes on (each side)
  double jawLengthMm = 10;    // (0, 200] a jaw's size along the faces: the grasp rectangle's height
  double jawThicknessMm = 5;  // (0, 50] a jaw's size across, outside the opening (the footprint it needs free)
};

struct Grasp {
  double u = 0, v = 0;        // centre, px
  double angleDeg = 0;        // closing axis, (-90, 90], counter-clockwise as displayed
  double widthPx = 0;         // opening across, px (the section plus both clearances)
  double jawPx = 0;           // jaw length along, px (at the centre's depth)
  double quality = 0;         // [0, 1]; the analytic detector: 1 for every grasp it finds
  double depthMm = 0;         // z at the centre (median of the valid depths within 2 px), mm
  double heightMm = 0;        // the centre's height above the floor, mm
  double widthMm = 0;         // opening, mm (at the centre's depth)
};

struct GraspDetectorOptions {
  std::string detector = "ggcnn";  // a graspDetectorNames() name
  std::string modelPath;           // ggcnn: the ONNX file (required)
  double minQuality = 0.2;         // [0, 1] ggcnn: peaks below this are not grasps ("not found"); from the validation sweep (docs/grasp.md)
  int maxGrasps = 5;               // [1, 100] at most this many grasps, best first
  // ggcnn: the jaws checked on the height map (docs/grasp.md "Network"): the opening and the
  // centre across read from where each jaw first finds room to come down to the centre's
  // height (at least jawMarginMm below it), a peak without room within the gripper's opening
  // dropped, and the quality weighed by exp(-d^2 / 2 openingSigmaMm^2), d the difference between
  // the network's opening and the one read (0: not weighed). Off: the network's maps as they are.
  bool checkJaws = true;
  double jawMarginMm = 2;          // [0, 100]
  double openingSigmaMm = 3;       // [0, 100]
  Gripper gripper;
  FloorOptions floor;
  // What counts as an object above the floor (mm, px at full resolution). maxObjectHeightMm
  // is for both detectors (ggcnn: a grasp centre higher than it is dropped); the rest analytic.
  double minObjectHeightMm = 3;    // (0, 1000] pixels at least this high are objects
  double maxObjectHeightMm = 80;   // objects reaching higher are not grasped (bin walls, fixtures)
  int minObjectAreaPx = 150;       // [1, 1e7] smaller blobs are noise
};

constexpr int kMinFrameSide = 48;  // px: smaller depth images are refused

// A depth frame as a detector sees it.
struct DepthFrame {
  cv::Mat zMm;                 // CV_32FC1, mm, 0 = no data, of the intrinsics' size
  DepthIntrinsics camera;
  std::string name;            // for messages: the file it came from
};

class GraspDetector {
 public:
  virtual ~GraspDetector() = default;
  virtual std::string_view name() const = 0;
  // Grasps best first; empty = nothing graspable (not an error). Errors (Status::BadArgument,
  // naming frame.name): a depth image of another size or type than the intrinsics say, a
  // frame with no floor plane.
  virtual Result<std::vector<Grasp>> detect(const DepthFrame& frame) = 0;
};

const std::vector<std::string>& graspDetectorNames();  // {"ggcnn", "analytic"}

// Errors (Status::BadArgument): an unknown detector name, an option out of range, an ONNX
// file that is missing or does not load ("PATH: cannot load the grasp network: why").
Result<std::unique_ptr<GraspDetector>> makeGraspDetector(const GraspDetectorOptions& options);

// Checks a frame's image against its intrinsics (shared by the detectors).
Result<void> checkFrame(const DepthFrame& frame);

}  // namespace vgr::vision::grasp
