#include "tools/vgr/classify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/dataset_file.hpp"
#include "config/job.hpp"
#include "daemon/job_locator.hpp"
#include "tools/vgr/eval_report.hpp"
#include "vision/classify/part_classifier.hpp"
#include "vision/classify/part_features.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::tools {
namespace {

namespace fs = std::filesystem;
namespace cls = vgr::vision::classify;

// The blob a detection stands on and the truth part that blob is: the blob whose centroid is
// nearest the detection within its equivalent radius (as ClassifyingLocator pairs them), and
// the truth part nearest that centroid within the same radius. -1 when there is none.
struct Pairing {
  int blob = -1, truth = -1;
};

Pairing pair(const vision::Detection& d, const std::vector<cls::PartBlob>& blobs, const std::vector<TruthPart>& truth) {
  Pairing p;
  double best = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    const double r = std::sqrt(blobs[i].areaPx / M_PI), dist = std::hypot(blobs[i].cx - d.u, blobs[i].cy - d.v);
    if (dist <= r && dist < best) best = dist, p.blob = static_cast<int>(i);
  }
  if (p.blob < 0) return p;
  const cls::PartBlob& b = blobs[static_cast<std::size_t>(p.blob)];
  const double r = std::sqrt(b.areaPx / M_PI);
  best = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double dist = std::hypot(truth[i].u - b.cx, truth[i].v - b.cy);
    if (dist <= r && dist < best) best = dist, p.truth = static_cast<int>(i);
  }
  return p;
}

// The dataset's class names in label order: dataset.yaml `classes`, else the labels of
// truth.csv sorted. Labels are 1-based indices into it.
Result<std::vector<std::string>> datasetClasses(const std::string& dir, const std::vector<TruthImage>& truth) {
  const std::string yaml = (fs::path(dir) / "dataset.yaml").string();
  if (fs::exists(yaml)) {
    auto d = config::loadDatasetFile(yaml);
    if (!d) return std::unexpected(d.error());
    if (!d->classes.empty()) return d->classes;
  }
  std::vector<std::string> names;
  for (const auto& im : truth)
    for (const auto& p : im.parts)
      if (!p.label.empty() && std::find(names.begin(), names.end(), p.label) == names.end()) names.push_back(p.label);
  std::sort(names.begin(), names.end());
  if (names.size() < 2)
    return fail(Status::BadArgument, dir + "/truth.csv: a 'label' column with at least two classes is needed (docs/datasets.md)");
  return names;
}

int classOf(const std::vector<std::string>& names, const std::string& label) {
  const auto it = std::find(names.begin(), names.end(), label);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

// A job for the dataset's parts: its template, method moments (every blob a part, paper 002's
// contour detection), all parts per image.
Result<void> makeJob(const std::string& datasetDir, const std::string& jobDir, int threshold) {
  auto t = config::loadPartTemplateFile((fs::path(datasetDir) / "template.yaml").string());
  if (!t) return std::unexpected(t.error());
  std::error_code ec;
  fs::create_directories(jobDir, ec);
  if (ec) return fail(Status::BadArgument, fmt::format("{}: cannot create the job folder: {}", jobDir, ec.message()));
  config::JobFile job;
  job.folder = jobDir;
  job.name = fs::path(jobDir).filename().string();
  job.method = "moments";
  job.grasps = {t->grasp};
  job.taught.grasp = t->grasp;
  job.taught.minScore = 0;  // symmetric parts have no moments score (moments_locator.hpp)
  job.taught.maxParts = 64;
  job.partHeightMm = t->graspHeightMm;
  job.taught.params["threshold"] = std::to_string(threshold);
  job.taught.params["min_area_px"] = "1500";
  // Every blob is a candidate: the classifier, not the template's shape, decides what it is.
  job.taught.params["shape_check"] = "false";
  fs::copy_file(fs::path(datasetDir) / t->image, fs::path(jobDir) / job.templateImage, fs::copy_options::overwrite_existing, ec);
  if (ec) return fail(Status::BadArgument, fmt::format("{}: cannot copy the template: {}", jobDir, ec.message()));
  return config::writeJob(job);
}

std::vector<int> parseSizes(const std::string& text) {
  std::vector<int> out;
  std::string cur;
  for (char c : text + ",") {
    if (c != ',') {
      cur += c;
      continue;
    }
    try {
      std::size_t used = 0;
      const int v = std::stoi(cur, &used);
      if (used != cur.size() || v < 1 || v > 1024) return {};
      out.push_back(v);
    } catch (const std::exception&) {
      return {};
    }
    cur.clear();
  }
  return out;
}

// Runs `locator` over the dataset; for every detection paired with a truth part calls
// onPart(features, class index or -1 for a class not in `names`, detection), for every other
// detection onExtra(detection).
template <class OnPart, class OnExtra>
Result<int> walk(const std::string& dir, const std::vector<TruthImage>& truth, const std::vector<std::string>& names,
                 vision::Locator& locator, int threshold, OnPart onPart, OnExtra onExtra, int& truthParts) {
  int images = 0;
  truthParts = 0;
  for (const auto& im : truth) {
    const std::string path = (fs::path(dir) / im.image).string();
    const cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (img.empty()) return fail(Status::BadArgument, path + ": cannot read the image");
    auto out = locator.locate(img);
    if (!out) return fail(out.error().code, path + ": " + out.error().message);
    auto blobs = cls::segmentParts(img, threshold, 200);
    if (!blobs) return std::unexpected(blobs.error());
    std::vector<bool> used(im.parts.size(), false);
    for (const auto& d : out->parts) {
      const Pairing p = pair(d, *blobs, im.parts);
      if (p.truth < 0 || used[static_cast<std::size_t>(p.truth)]) {
        onExtra(d);
        continue;
      }
      used[static_cast<std::size_t>(p.truth)] = true;
      // c = -1: a truth part of a class the classifier does not know (a novel part).
      const int c = classOf(names, im.parts[static_cast<std::size_t>(p.truth)].label);
      onPart((*blobs)[static_cast<std::size_t>(p.blob)].features, c, d);
    }
    truthParts += static_cast<int>(im.parts.size());
    ++images;
  }
  return images;
}

// One-vs-rest counts of class k (paper 002 Table 3) from the confusion matrix; a rejected
// part (last column) is a false negative of its true class and no one's false positive.
struct Counts {
  long tp = 0, fp = 0, fn = 0, tn = 0;
};
Counts counts(const std::vector<std::vector<long>>& m, std::size_t k) {
  Counts c;
  const std::size_t n = m.size();
  for (std::size_t t = 0; t < n; ++t)
    for (std::size_t p = 0; p <= n; ++p) {
      const long v = m[t][p];
      if (t == k && p == k) c.tp += v;
      else if (t == k) c.fn += v;
      else if (p == k) c.fp += v;
      else c.tn += v;
    }
  return c;
}
double ratio(double a, double b) { return b > 0 ? a / b : 0; }

Result<void> writeConfusionPng(const std::string& path, const std::vector<std::string>& names,
                               const std::vector<std::vector<long>>& m) {
  const int n = static_cast<int>(names.size()), cell = 64, left = 150, top = 150;
  cv::Mat img(top + cell * n + 40, left + cell * (n + 1) + 20, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  for (int t = 0; t < n; ++t) {
    long rowSum = 0;
    for (int p = 0; p <= n; ++p) rowSum += m[t][p];
    for (int p = 0; p <= n; ++p) {
      const double f = rowSum ? double(m[t][p]) / rowSum : 0;
      const cv::Rect r(left + p * cell, top + t * cell, cell, cell);
      // White (0) to blue (1) for the diagonal, to red for confusions.
      const int fade = static_cast<int>(255 * (1 - f));
      const cv::Scalar color = p == t ? cv::Scalar(255, fade, fade) : cv::Scalar(fade, fade, 255);
      cv::rectangle(img, r, color, cv::FILLED);
      cv::rectangle(img, r, cv::Scalar(160, 160, 160), 1);
      const std::string text = std::to_string(m[t][p]);
      cv::putText(img, text, {r.x + 8, r.y + cell / 2 + 6}, font, 0.5, f > 0.6 ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0), 1,
                  cv::LINE_AA);
    }
    cv::putText(img, names[static_cast<std::size_t>(t)], {8, top + t * cell + cell / 2 + 6}, font, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  for (int p = 0; p <= n; ++p) {
    const std::string name = p < n ? names[static_cast<std::size_t>(p)] : "unknown";
    const cv::Point at(left + p * cell + cell / 2 - 4, top - 8);
    // Column names written upward.
    cv::Mat label(24, 140, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(label, name, {2, 17}, font, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::Mat up;
    cv::rotate(label, up, cv::ROTATE_90_COUNTERCLOCKWISE);
    const cv::Rect dst(at.x - 12, at.y - up.rows, up.cols, up.rows);
    if ((dst & cv::Rect(0, 0, img.cols, img.rows)) == dst) up.copyTo(img(dst));
  }
  cv::putText(img, "rows: true class, columns: predicted (paper 002 Table 3 counts per class)", {8, img.rows - 14}, font, 0.4,
              cv::Scalar(80, 80, 80), 1, cv::LINE_AA);
  if (!cv::imwrite(path, img)) return fail(Status::BadArgument, path + ": cannot write the PNG");
  return {};
}

}  // namespace

int runClassifyTrain(const ClassifyTrainOptions& o) {
  auto truth = readTruth(o.dataset);
  if (!truth) return badInput(truth.error().message);
  auto names = datasetClasses(o.dataset, *truth);
  if (!names) return badInput(names.error().message);
  const std::vector<int> hidden = parseSizes(o.hidden);
  if (hidden.empty()) return badInput(fmt::format("--hidden: expected layer sizes like 32,16 (each 1..1024), got '{}'", o.hidden));
  if (!fs::exists(fs::path(o.out) / "job.yaml"))
    if (auto m = makeJob(o.dataset, o.out, o.threshold); !m) return badInput(m.error().message);
  auto job = config::loadJob(o.out);
  if (!job) return badInput(job.error().message);
  job->classify = {};  // train on the method's parts alone
  auto locator = daemon::makeJobLocator(*job);
  if (!locator) return badInput(locator.error().message);

  std::vector<cls::FeatureVector> x;
  std::vector<int> y;
  int extra = 0, truthParts = 0;
  auto walked = walk(
      o.dataset, *truth, *names, **locator, o.threshold,
      [&](const cls::FeatureVector& f, int c, const vision::Detection&) {
        if (c < 0) return;  // unreachable: names are the dataset's own labels
        x.push_back(f);
        y.push_back(c);
      },
      [&](const vision::Detection&) { ++extra; }, truthParts);
  if (!walked) return badInput(walked.error().message);
  cls::TrainOptions to;
  to.hidden = hidden;
  to.maxIterations = o.iterations;
  to.seed = o.seed;
  auto model = cls::PartClassifier::train(x, y, *names, to);
  if (!model) return badInput(o.dataset + ": " + model.error().message);
  int correct = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (model->predict(x[i], 0, 0).best == y[i] + 1) ++correct;

  job->classify.model = "classifier.yaml";
  job->classify.minConfidence = o.minConfidence;
  job->classify.maxFeatureZ = o.maxFeatureZ;
  job->classify.threshold = o.threshold;
  if (auto s = model->save(job->classifierPath()); !s) return badInput(s.error().message);
  if (auto w = config::writeJob(*job); !w) return badInput(w.error().message);
  if (auto back = daemon::makeJobLocator(*job); !back) return badInput("written classifier does not load: " + back.error().message);
  std::printf("%s: classifier %d-%s-%zu on %zu parts of %d images (%d truth parts, %d other detections), training accuracy %.2f %%\n",
              o.out.c_str(), cls::kFeatureCount, model->layersText().c_str(), names->size(), x.size(), *walked, truthParts, extra,
              100.0 * ratio(correct, static_cast<double>(x.size())));
  return 0;
}

int runClassifyEval(const ClassifyEvalOptions& o) {
  auto job = config::loadJob(o.job);
  if (!job) return badInput(job.error().message);
  if (job->classify.model.empty()) return badInput(o.job + "/job.yaml: no 'classify' section (run vgr classify train)");
  auto model = cls::PartClassifier::load(job->classifierPath());
  if (!model) return badInput(model.error().message);
  auto truth = readTruth(o.dataset);
  if (!truth) return badInput(truth.error().message);
  const std::vector<std::string>& names = model->classNames();
  job->classify.keepUnknown = true;  // count the unsure parts (label 0) instead of losing them
  auto locator = daemon::makeJobLocator(*job);
  if (!locator) return badInput(locator.error().message);

  const std::size_t n = names.size();
  std::vector<std::vector<long>> m(n, std::vector<long>(n + 1, 0));  // [true][predicted], column n = unknown
  long extraServed = 0, extraTotal = 0, novelServed = 0, novelTotal = 0;
  int truthParts = 0;
  auto walked = walk(
      o.dataset, *truth, names, **locator, job->classify.threshold,
      [&](const cls::FeatureVector&, int c, const vision::Detection& d) {
        if (c < 0) {  // a part of a class the classifier was not trained on: should be unknown
          ++novelTotal;
          if (d.label > 0) ++novelServed;
          return;
        }
        const std::size_t p = d.label >= 1 && d.label <= static_cast<int>(n) ? static_cast<std::size_t>(d.label - 1) : n;
        ++m[static_cast<std::size_t>(c)][p];
      },
      [&](const vision::Detection& d) {
        ++extraTotal;
        if (d.label > 0) ++extraServed;
      },
      truthParts);
  if (!walked) return badInput(walked.error().message);

  long found = 0, rejected = 0, correct = 0;
  for (std::size_t t = 0; t < n; ++t)
    for (std::size_t p = 0; p <= n; ++p) {
      found += m[t][p];
      if (p == n) rejected += m[t][p];
      if (p == t) correct += m[t][p];
    }
  const double accuracy = ratio(correct, double(found - rejected)), rejectRate = ratio(rejected, double(found));
  nlohmann::ordered_json j;
  nlohmann::ordered_json perClass = nlohmann::ordered_json::object();
  double sums[5] = {0, 0, 0, 0, 0};
  std::printf("classify eval: %s on %s: %d images, %d truth parts, %ld found, %ld rejected (unknown)\n", o.job.c_str(),
              o.dataset.c_str(), *walked, truthParts, found, rejected);
  std::printf("%-14s %6s %6s %6s %6s  %8s %8s %8s %8s %8s\n", "class", "TP", "FP", "FN", "TN", "sens %", "spec %", "prec %",
              "acc %", "F1 %");
  for (std::size_t k = 0; k < n; ++k) {
    const Counts c = counts(m, k);
    // Paper 002 eqs. 14-18.
    const double sens = ratio(c.tp, double(c.tp + c.fn)), spec = ratio(c.tn, double(c.tn + c.fp));
    const double prec = ratio(c.tp, double(c.tp + c.fp)), acc = ratio(c.tp + c.tn, double(c.tp + c.tn + c.fp + c.fn));
    const double f1 = ratio(2 * prec * sens, prec + sens);
    for (int i = 0; const double v : {sens, spec, prec, acc, f1}) sums[i++] += v;
    std::printf("%-14s %6ld %6ld %6ld %6ld  %8.2f %8.2f %8.2f %8.2f %8.2f\n", names[k].c_str(), c.tp, c.fp, c.fn, c.tn, 100 * sens,
                100 * spec, 100 * prec, 100 * acc, 100 * f1);
    perClass[names[k]] = {{"tp", c.tp}, {"fp", c.fp}, {"fn", c.fn}, {"tn", c.tn}, {"sensitivity", sens},
                          {"specificity", spec}, {"precision", prec}, {"accuracy", acc}, {"f1", f1}};
  }
  const double k = n ? static_cast<double>(n) : 1;
  std::printf("%-14s %27s  %8.2f %8.2f %8.2f %8.2f %8.2f   (mean over classes, as paper 002 Table 5)\n", "macro", "",
              100 * sums[0] / k, 100 * sums[1] / k, 100 * sums[2] / k, 100 * sums[3] / k, 100 * sums[4] / k);
  std::printf("accuracy (correct / classified) %.2f %%, accuracy with rejections as errors %.2f %%, macro F1 %.2f %%, reject rate %.2f %%\n",
              100 * accuracy, 100 * ratio(correct, double(found)), 100 * sums[4] / k, 100 * rejectRate);
  std::printf("other detections (not a truth part): %ld, of them given a class: %ld\n", extraTotal, extraServed);
  if (novelTotal) std::printf("parts of classes the classifier does not know: %ld, of them given a class: %ld\n", novelTotal, novelServed);
  std::printf("confusion matrix (rows true, columns predicted, last = unknown):\n%-14s", "");
  for (std::size_t p = 0; p <= n; ++p) std::printf(" %8.8s", p < n ? names[p].c_str() : "unknown");
  std::printf("\n");
  for (std::size_t t = 0; t < n; ++t) {
    std::printf("%-14s", names[t].c_str());
    for (std::size_t p = 0; p <= n; ++p) std::printf(" %8ld", m[t][p]);
    std::printf("\n");
  }
  const std::string png = o.png.empty() ? (fs::path(o.job) / "confusion.png").string() : o.png;
  if (auto w = writeConfusionPng(png, names, m); !w) return badInput(w.error().message);
  std::printf("confusion matrix PNG: %s\n", png.c_str());
  if (o.json) {
    j["images"] = *walked;
    j["truth_parts"] = truthParts;
    j["found"] = found;
    j["rejected"] = rejected;
    j["accuracy"] = accuracy;
    j["accuracy_with_rejects"] = ratio(correct, double(found));
    j["macro_sensitivity"] = sums[0] / k;
    j["macro_specificity"] = sums[1] / k;
    j["macro_precision"] = sums[2] / k;
    j["macro_accuracy"] = sums[3] / k;
    j["macro_f1"] = sums[4] / k;
    j["reject_rate"] = rejectRate;
    j["other_detections"] = extraTotal;
    j["other_detections_classified"] = extraServed;
    j["novel_parts"] = novelTotal;
    j["novel_parts_classified"] = novelServed;
    j["classes"] = names;
    j["per_class"] = perClass;
    j["confusion"] = m;
    j["png"] = png;
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

CLI::App* ClassifyTrainCommand::add(CLI::App& parent) {
  auto& t = options_;
  auto* cmd = parent.add_subcommand("train", "train the part classifier of a job on a labelled dataset (docs/classification.md)");
  cmd->add_option("--dataset", t.dataset, "dataset folder with a label column in truth.csv")->required();
  cmd->add_option("--out", t.out, "job folder (created from the dataset's template when it has no job.yaml)")->required();
  cmd->add_option("--hidden", t.hidden, "hidden layer sizes, comma-separated");
  cmd->add_option("--iterations", t.iterations, "RPROP epochs")->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", t.seed, "initial weights seed");
  cmd->add_option("--min-confidence", t.minConfidence, "[0, 1]: below = unknown (job.yaml classify.min_confidence)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--max-feature-z", t.maxFeatureZ, "features this many class std from the class mean = unknown; 0 = off")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--threshold", t.threshold, "gray level segmenting the parts, 0 = Otsu")->check(CLI::Range(0, 255));
  return cmd;
}

CLI::App* ClassifyEvalCommand::add(CLI::App& parent) {
  auto& e = options_;
  auto* cmd = parent.add_subcommand("eval", "score a job's classifier on a labelled dataset (docs/classification.md)");
  cmd->add_option("--job", e.job, "job folder with a classify section")->required();
  cmd->add_option("--dataset", e.dataset, "held-out dataset folder with a label column in truth.csv")->required();
  cmd->add_option("--png", e.png, "confusion matrix PNG (default JOB/confusion.png)");
  cmd->add_flag("--json", e.json, "one final JSON line: accuracy, macro_f1, reject_rate, per_class, confusion");
  return cmd;
}

}  // namespace vgr::tools
