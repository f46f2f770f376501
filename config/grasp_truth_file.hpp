// DIR/grasps.csv of a 3D data set made with `vgr sim render --3d --grasps` (docs/grasp.md
// "Ground truth"; sim/grasp_truth.hpp makes the rows): one row per true grasp rectangle,
//   image,part,grasp,sample,u_px,v_px,angle_deg,width_px,jaw_px,x_mm,y_mm,z_mm,width_mm
// image: as in truth.csv (images/0000.png); part: index of the part in the image (its row
// order in truth.csv); grasp: the canonical grasp's name; sample: index along its segment
// (samples k and k + 1 are 2 mm apart); u, v: centre px; angle: the closing axis, degrees
// counter-clockwise as displayed, (-90, 90]; width: opening, jaw: jaw length (px);
// x, y, z: the grasp centre in the camera frame (mm); width_mm: opening in mm. An image
// without a graspable part has one row with empty fields. Parse -> validate; errors name
// the file and line. Start-up style I/O, any thread.
#pragma once

#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::config {

struct GraspTruthRow {
  std::string image;
  bool hasGrasp = false;   // false: the image's one row with empty fields
  int part = 0;
  std::string grasp;
  int sample = 0;
  double u = 0, v = 0, angleDeg = 0, widthPx = 0, jawPx = 0;
  double xMm = 0, yMm = 0, zMm = 0, widthMm = 0;
  int line = 0;
};

std::string graspTruthCsvHeader();
std::string graspTruthCsvRow(const GraspTruthRow& row);  // hasGrasp false: empty fields

// Errors (Status::BadArgument): "PATH: cannot open", "PATH:1: the header must be ...",
// "PATH:LINE: column 'u_px': expected a number, got 'x'", a negative part or sample, an
// angle outside (-90, 90], a width, jaw or depth that is not > 0, an image with both an
// empty row and grasp rows.
Result<std::vector<GraspTruthRow>> loadGraspTruth(const std::string& path);

}  // namespace vgr::config
