// `vgr model build|eval`: part models for 3D jobs from depth views (paper 004 Sec. 3.1;
// docs/3d.md "Model building").
//   build --views DIR/views --out JOB: the views in DIR/views/views.csv (the camera's pose in
//         the model frame as the robot reported it; DIR/camera.yaml the depth camera), merged
//         by vision/cloud/model_builder.hpp into a 3D job folder (job.yaml of kind 3d,
//         model.ply in the frame the view poses are given in, model_report.json); the report
//         (per view and per edge: fitness, RMSE, what was left out and why) on stdout, a
//         progress line per step on stderr, with --json one final JSON line.
//   eval  --job JOB --mesh DIR/mesh.ply [--json]: the job's model against a true surface
//         after one rigid alignment: mean, 95th percentile and max distance (mm).
// Exit code 0; 1 when the views cannot make a model (too few registered: the reason names
// them); 2 with the message on stderr for bad input (nothing written). One thread.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct ModelBuildOptions {
  std::string views, out, name;
  double viewVoxelMm = 1.5, modelVoxelMm = 1.0, maxPoseDisagreementMm = 10.0, minFitness = 0.3;
  int threads = 1;
  bool json = false;
};

struct ModelEvalOptions {
  std::string job, mesh;
  bool json = false;
};

int runModelBuild(const ModelBuildOptions& o);
int runModelEval(const ModelEvalOptions& o);

class ModelBuildCommand final : public OptionsSubcommand<ModelBuildOptions, runModelBuild> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

class ModelEvalCommand final : public OptionsSubcommand<ModelEvalOptions, runModelEval> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
