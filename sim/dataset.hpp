// Writes a localization dataset (docs/datasets.md) from the PartSceneRenderer: images,
// truth.csv, the template to teach on (template.png + template.yaml) and dataset.yaml (the
// options it was made with). Used by `vgr sim render`; start-up style I/O, one thread.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.hpp"
#include "sim/part_scene.hpp"

namespace vgr::sim {

struct DatasetOptions {
  std::string outDir;
  int count = 100;            // images
  std::string part = "multi";  // "flat" or "multi"
  int levels = 3;             // multi: height levels [2, 4]
  // Several part classes (PartModel::byName names) mixed in every image, each part's class
  // in truth.csv's `label` column; empty = `part` alone (the files exactly as without it).
  std::vector<std::string> classes;
  PartSceneOptions scene;
};

struct DatasetSummary {
  int images = 0, emptyImages = 0, parts = 0;
};

// Creates outDir (and parents) if needed; overwrites files of the same names.
Result<DatasetSummary> writeDataset(const DatasetOptions& options);

// The part's template to teach on: DIR/template.png and DIR/template.yaml (grasp point,
// grasp height, crop offset, the levels' top faces as paper 000's regions). DIR must exist.
Result<PartTemplate> writePartTemplate(const PartSceneRenderer& renderer, const std::string& dir);

// The renderer a dataset's options describe (shared with tests). Errors: an unknown class.
Result<PartSceneRenderer> datasetRenderer(const DatasetOptions& options);

}  // namespace vgr::sim
