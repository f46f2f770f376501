// The part classifier of paper 002 (Sec. 3, "MLP classifier"; Sec. 4, confidence threshold):
// a multilayer perceptron (OpenCV's cv::ml::ANN_MLP) from the shape features of
// part_features.hpp to one output per class, with a confidence made from the outputs and two
// rejections: below `minConfidence`, or features far outside what the class was trained on.
//
// Network (docs/classification.md "Network"): 14 inputs -> hidden layers (default 32, 16) ->
// one output per class; symmetric sigmoid (ANN_MLP::SIGMOID_SYM) units; one-hot targets
// (1 for the class, 0 otherwise); trained by RPROP on the whole set. Paper 002 tuned
// scikit-learn's MLPClassifier (softmax output, adam, early stopping) by RandomizedSearchCV;
// its chosen hyperparameters are printed only as a figure, and OpenCV has neither softmax
// outputs nor adam, so this is the nearest OpenCV network, not a copy (docs say why).
//
// Confidence: the outputs clamped to [0, 1], c = max * max / sum ("normalised max", times the
// max itself so that a part no output claims stays low). Labels are 1-based class indices;
// 0 = unknown (rejected).
//
// File: one YAML (cv::FileStorage) holding the class names, the feature names and count, the
// per-class feature mean / std, and the ANN_MLP under `mlp` (its own input/output scaling).
// Threads: predict() is const but ANN_MLP::predict is not documented thread-safe: one thread
// per instance.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/result.hpp"
#include "vision/classify/part_features.hpp"

namespace vgr::vision::classify {

struct TrainOptions {
  std::vector<int> hidden = {32, 16};  // hidden layer sizes
  int maxIterations = 3000;            // RPROP epochs
  double epsilon = 0;                  // > 0: also stop when the error changes less than this
  std::uint64_t seed = 42;             // initial weights (paper 002's random_state 42)
};

struct Prediction {
  int label = 0;          // 1-based class, 0 = unknown (rejected)
  int best = 0;           // 1-based class of the largest output, before rejection
  double confidence = 0;  // [0, 1]
  double featureZ = 0;    // largest |feature - class mean| / class std, for the best class
};

class PartClassifier {
 public:
  // features[i] of class classIndex[i] (0-based into classNames). Errors: BadArgument for
  // empty or mismatched input, a class without samples.
  static Result<PartClassifier> train(const std::vector<FeatureVector>& features, const std::vector<int>& classIndex,
                                      std::vector<std::string> classNames, const TrainOptions& options = {});
  // Errors name the file: missing, not a classifier, feature count not kFeatureCount.
  static Result<PartClassifier> load(const std::string& path);
  Result<void> save(const std::string& path) const;

  // maxFeatureZ 0 = no feature-range rejection.
  Prediction predict(const FeatureVector& features, double minConfidence, double maxFeatureZ) const;
  // The raw outputs (one per class), for tests.
  std::vector<float> outputs(const FeatureVector& features) const;

  const std::vector<std::string>& classNames() const;
  // "32,16"
  std::string layersText() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace vgr::vision::classify
