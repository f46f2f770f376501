// `vgr classify train|eval`: paper 002's part classifier (docs/classification.md).
//   train --dataset DIR --out JOBDIR: the job in JOBDIR (made from the dataset's template with
//         method moments when JOBDIR has no job.yaml) finds the parts of every image; each part
//         matched to a truth part gets that part's `label` (truth.csv); the MLP is trained on
//         their features and written to JOBDIR/classifier.yaml, and job.yaml gains `classify:`.
//   eval  --job JOBDIR --dataset DIR [--json] [--png FILE]: the job (with its classifier) run on
//         a held-out dataset: per-class and overall sensitivity, specificity, precision,
//         accuracy, F1 (paper 002 eqs. 14-18), the confusion matrix, the reject rate; text,
//         a PNG of the confusion matrix, and with --json one final JSON line.
// Exit code 0, 2 with the message on stderr for bad input. One thread.
#pragma once

#include <cstdint>
#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct ClassifyTrainOptions {
  std::string dataset, out;
  std::string hidden = "32,16";  // hidden layer sizes
  int iterations = 3000;
  std::uint64_t seed = 42;
  double minConfidence = 0.8;
  double maxFeatureZ = 8;
  int threshold = 60;            // gray level segmenting parts (job's classify.threshold and moments threshold)
};

struct ClassifyEvalOptions {
  std::string job, dataset, png;  // png empty = JOBDIR/confusion.png
  bool json = false;
};

int runClassifyTrain(const ClassifyTrainOptions& o);
int runClassifyEval(const ClassifyEvalOptions& o);

class ClassifyTrainCommand final : public OptionsSubcommand<ClassifyTrainOptions, runClassifyTrain> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

class ClassifyEvalCommand final : public OptionsSubcommand<ClassifyEvalOptions, runClassifyEval> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
