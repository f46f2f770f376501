// A Locator decorator (paper 002 Sec. 2, "identification" stage): runs the job's method, then
// classifies every part it found and sets Detection::label and Detection::confidence.
//
// Each detection is matched to a blob of the same image segmented by a global threshold
// (part_features.hpp): the blob whose centroid is nearest to the detection's (u, v), within
// the blob's own equivalent radius sqrt(area / pi). A detection without a blob, or
// whose class is unsure (confidence below the job's min_confidence, or features outside what
// the class was trained on), gets label 0 = "unknown" and stays in the list: it is still a
// part on the belt (the robot may clear it with part_order best_score / random), but a
// `label_only` order never serves it and `by_label` serves it last (docs/classification.md
// "Unsure parts"). Order of detections: as the method returned them.
//
// Threads: as Locator (one thread at a time).
#pragma once

#include <memory>

#include "vision/classify/part_classifier.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision::classify {

struct ClassifyParams {
  double minConfidence = 0.8;  // [0, 1]
  double maxFeatureZ = 8;      // 0 = off
  int threshold = 0;           // segmentation gray level, 0 = Otsu
  double minAreaPx = 200;      // blobs smaller than this are not parts
};

std::unique_ptr<Locator> makeClassifyingLocator(std::unique_ptr<Locator> inner, PartClassifier classifier,
                                                const ClassifyParams& params);

}  // namespace vgr::vision::classify
