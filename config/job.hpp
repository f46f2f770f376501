// Job folders (recipes, docs/localization.md "Jobs"): `job.yaml` + the template image +
// derived model files. A job is what `vgr teach` writes and what `vgr locate`, `vgr eval`
// and vgrd (cell config `jobs[].folder`) load. Parse -> validate; errors name the file,
// the line and the key: "JOB/job.yaml:12: key 'regions[1].height_factor': expected ...".
// Plain data, no images: the caller reads the template (templatePath()) and builds the
// method with vision::makeLocator(method, template, taught) (config links no vision code).
#pragma once

#include <string>
#include <vector>

#include "core/result.hpp"
#include "core/taught_template.hpp"

namespace vgr::config {

struct JobFile {
  std::string folder;                      // the job folder it was loaded from / is written to
  std::string name;                        // free text
  std::string method = "moments";          // a name of vision::locatorMethods()
  std::string templateImage = "template.png";  // relative to folder
  // Grasp points in template px; the first is the one the locator transfers
  // (taught.grasp), the others are kept for the robot program (e.g. alternative grips).
  std::vector<PixelPoint> grasps;
  TaughtTemplate taught;                   // grasp, ROI, thresholds, regions, method params (+ where written)
  double partHeightMm = 0;                 // mm, [0, 1000]: grasp height above the conveyor plane
  // Reference pose the offsets are given from (robot base frame) and where the part lay in
  // the template (px, deg): the taught pose.
  double referenceXMm = 0, referenceYMm = 0, referenceZMm = 0, referenceRzDeg = 0;
  bool referenceGiven = false;  // job.yaml has a `reference` (robots delivering offsets need one)
  // Optional: a cell config (relative to folder) whose mapping (calibration files, a
  // multi-height map, else its `model`) maps pixels to the robot frame exactly as vgrd does;
  // empty = not calibrated (vgr locate then reports pixels only).
  std::string calibration;
  // Optional (paper 002 Sec. 3, "MLP classifier"): a part classifier run on every part the
  // method finds (docs/classification.md). job.yaml `classify: {model: classifier.yaml,
  // min_confidence: 0.8, max_feature_z: 8, threshold: 0, keep_unknown: false}`; absent = no
  // classifier (every part keeps label 0). A part the classifier is unsure of (below
  // min_confidence, or features outside its class) is dropped ("not found"), or with
  // keep_unknown kept with label 0 = unknown.
  struct Classify {
    std::string model;           // relative to folder; empty = no classifier
    double minConfidence = 0.8;  // [0, 1]: paper 002 Sec. 4 used 0.96
    double maxFeatureZ = 8;      // >= 0: features farther from the class mean (in its std) = unknown; 0 = off
    int threshold = 0;           // gray level [0, 255] segmenting the part's blob; 0 = Otsu
    bool keepUnknown = false;    // unsure parts: false = dropped, true = kept with label 0
  } classify;

  std::string templatePath() const;
  std::string classifierPath() const;  // empty when classify.model is empty
  std::string calibrationPath() const;  // empty when calibration is empty
};

// Reads FOLDER/job.yaml. Errors: Status::BadArgument, "FILE:LINE: key 'k': what". Fields in
// template px are checked against the template's size read from its header (PNG, JPEG,
// BMP): a grasp point off the template, a region wholly outside it. This is the one loader
// vgrd's cell config, `vgr locate`, `vgr eval` and `vgr check` go through.
Result<JobFile> loadJob(const std::string& folder);
Result<JobFile> parseJob(const std::string& yamlText, const std::string& sourceName, const std::string& folder);

// Writes FOLDER/job.yaml (the folder must exist) with yaml-cpp's emitter: every string is
// escaped as YAML needs and every number written as the shortest text that reads back to
// the same double, so loadJob returns the job exactly (paramSources aside).
Result<void> writeJob(const JobFile& job);
std::string jobYaml(const JobFile& job);

// Reads a `regions:` list in the job.yaml schema from any YAML file (e.g. a dataset's
// template.yaml) for `vgr teach --regions`.
Result<std::vector<TemplateRegion>> loadRegions(const std::string& path);

// template.yaml: the template to teach a job on, as `vgr sim render` and `vgr demo` write it
// next to template.png (docs/datasets.md): the grasp point, its height, where the template
// was cut from the full image and the part's levels as a `regions:` list in the job.yaml
// schema. Written to a fixed precision a user copies from (grasp px 4 decimals, heights mm 3,
// polygon px 2); the truth to score against is the dataset's truth.csv.
struct PartTemplateFile {
  std::string image = "template.png";  // relative to the file's folder
  PixelPoint grasp;                    // template px
  double graspHeightMm = 0;            // mm above the conveyor plane
  int cropOffsetX = 0, cropOffsetY = 0;  // template px + offset = px of the full image
  std::vector<TemplateRegion> regions;
};
std::string partTemplateYaml(const PartTemplateFile& t);
Result<void> writePartTemplateFile(const std::string& path, const PartTemplateFile& t);
// Errors: Status::BadArgument, "FILE:LINE: key 'k': what".
Result<PartTemplateFile> loadPartTemplateFile(const std::string& path);

}  // namespace vgr::config
