// `vgr teach`: a job folder (job.yaml + template.png) from a template image and its grasp
// point(s) (docs/localization.md), or with --model a 3D job folder (job.yaml of kind 3d +
// model.ply) from a model cloud (docs/3d.md), written into OUT.partial-PID and renamed. The method must accept the template before anything is
// written; the job is read back after writing. Exit code 0, or 2 with the message on stderr.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "config/job3d.hpp"
#include "tools/vgr/subcommand.hpp"
#include "vision/ply_file.hpp"

namespace vgr::tools {

struct TeachOptions {
  std::string image, out, method = "moments", roi, regionsFile, name;
  std::vector<std::string> grasps, params;
  double minScore = 0.5, angleMin = -180, angleMax = 180, partHeightMm = 0;
  double scaleMin = 1, scaleMax = 1;  // image px per template px, [kMinPartScale, kMaxPartScale]
  int maxParts = 1;
  bool autoRegions = true;
  // 3D (docs/3d.md "Jobs"): a job of kind 3d from a model cloud (PLY x y z nx ny nz, mm);
  // the grasp pose in the model frame as X,Y,Z,QW,QX,QY,QZ (mm, unit quaternion), default
  // the model frame. --image / --grasp and --model exclude each other.
  std::string model, graspPose;
  // --polarity: params.polarity of moments, hu and shape (use | ignore_global | ignore_local);
  // empty = the method's default (use). A --param polarity=... says the same; both: an error.
  std::string polarity;
};

int runTeach(const TeachOptions& o);

// Writes a new 3D job folder OUT (job.yaml of kind 3d, model.ply with `comment` - the model
// is called modelName in messages - and the
// extra files given as name -> text) through OUT.partial-PID, renamed at the end; the 3D
// locator must accept the model first and the written job must load. Shared by `vgr teach
// --model` and `vgr model build`. Returns 0, or 2 with the message on stderr (nothing
// written).
int writeNew3dJob(const std::string& out, config::Job3dFile job, const vision::PlyCloud& cloud, const std::string& modelName,
                  const std::string& comment,
                  const std::vector<std::pair<std::string, std::string>>& extraFiles = {});

class TeachCommand final : public OptionsSubcommand<TeachOptions, runTeach> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
