// 3D job folders (docs/3d.md "Jobs"): job.yaml with `kind: 3d`, the part's model cloud
// (model.ply: x y z nx ny nz, mm, model frame), the taught grasp pose in the model frame and
// the search parameters (core/search3d.hpp). What `vgr teach --model` and `vgr model build`
// write and what `vgr locate`, `vgr eval` and vgrd load. Parse -> validate; errors name the
// file, the line and the key: "JOB/job.yaml:9: key 'search.f_h': expected a number in
// [0, 1], got '2'". Plain data: the caller reads the model (vision/ply_file.hpp) and builds
// the locator (vision/cloud/locator3d.hpp).
#pragma once

#include <string>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "core/search3d.hpp"

namespace vgr::config {

struct Job3dFile {
  std::string folder;                // loaded from / written to
  std::string name;                  // free text
  std::string model = "model.ply";   // relative to folder
  Pose grasp;                        // T_model_grasp: the gripper frame in the model frame (mm, unit quaternion)
  Search3dParams search;
  std::string modelPath() const;
};

// The `kind` of FOLDER/job.yaml: "2d" (also when the key is absent) or "3d". Errors: the
// file cannot be read or parsed, `kind` is something else (file:line:key).
Result<std::string> jobKind(const std::string& folder);

// Errors: Status::BadArgument "FILE:LINE: key 'k': what" (a missing or out-of-range key, an
// unknown key, a grasp quaternion that is not unit length, `kind` other than 3d).
Result<Job3dFile> loadJob3d(const std::string& folder);
Result<Job3dFile> parseJob3d(const std::string& yamlText, const std::string& sourceName, const std::string& folder);

// Writes FOLDER/job.yaml (the folder must exist); every number as the shortest text that
// reads back to the same double.
Result<void> writeJob3d(const Job3dFile& job);
std::string job3dYaml(const Job3dFile& job);

}  // namespace vgr::config
