// A Locator decorator (paper 002 Sec. 2, "identification" stage): runs the job's method, then
// classifies every part it found and sets Detection::label and Detection::confidence.
//
// Each detection is matched to a blob of the same image segmented by a global threshold
// (part_features.hpp): the blob whose centroid is nearest to the detection's (u, v), within
// the blob's own equivalent radius sqrt(area / pi). A detection without a blob, or whose
// class is unsure (confidence below the job's min_confidence, or features outside what the
// class was trained on), is dropped: it is "not found", so no robot is ever served a part
// under a class it may not have (robot replies carry no label: docs/protocols.md). With
// keepUnknown it stays in the list with label 0 = "unknown" instead (for `vgr classify eval`,
// and for a reject robot with part_order label_only, label 0; note that by_label, ascending,
// serves label 0 first). docs/classification.md "Unsure parts". Order: as the method returned.
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
  bool keepUnknown = false;    // unsure parts: false = dropped from the list, true = kept with label 0
};

std::unique_ptr<Locator> makeClassifyingLocator(std::unique_ptr<Locator> inner, PartClassifier classifier,
                                                const ClassifyParams& params);

}  // namespace vgr::vision::classify
