// dataset.yaml: how a `vgr sim render` dataset was made (docs/datasets.md): the renderer's
// options and the pinhole camera looking straight down (base frame origin on the plane under
// the optical centre). Written next to the images and truth.csv; `vgr eval` reads the
// camera from it for paper 001's rates. Numbers as the renderer was given them; the camera's
// focal length to 4 decimals and principal point to 2.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::config {

struct DatasetFile {
  std::string part = "multi";  // "flat" or "multi"
  int levels = 1;              // height levels (1 for flat)
  int count = 0;               // images
  std::uint64_t seed = 1;
  int width = 0, height = 0;   // px
  double angleRangeDeg = 0;
  int partsPerImage = 1;
  double emptyRatio = 0;
  int clutter = 0;
  double noiseSigma = 0, blurSigma = 0, illumRatio = 1;
  int decoys = 0;
  bool plain = false;          // texture-less top faces (`--plain`); key written only when true
  double fx = 0, fy = 0, cx = 0, cy = 0;  // px
  double cameraHeightMm = 0;              // optical centre above the plane, mm
  // `vgr sim render --classes`: the part classes mixed in the images, in label order (truth.csv
  // then has a `label` column with the class name). Empty = one part, key not written.
  std::vector<std::string> classes;
};

std::string datasetYaml(const DatasetFile& d);
Result<void> writeDatasetFile(const std::string& path, const DatasetFile& d);
// Errors: Status::BadArgument, "FILE:LINE: key 'k': what".
Result<DatasetFile> loadDatasetFile(const std::string& path);

}  // namespace vgr::config
