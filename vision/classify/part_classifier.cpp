#include "vision/classify/part_classifier.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

namespace vgr::vision::classify {

struct PartClassifier::Impl {
  cv::Ptr<cv::ml::ANN_MLP> mlp;
  std::vector<std::string> names;
  std::vector<int> hidden;
  cv::Mat mean, stddev;  // classes x kFeatureCount, CV_32F
};

namespace {

cv::Mat row(const FeatureVector& f) { return cv::Mat(1, kFeatureCount, CV_32F, const_cast<float*>(f.data())).clone(); }

}  // namespace

Result<PartClassifier> PartClassifier::train(const std::vector<FeatureVector>& features, const std::vector<int>& classIndex,
                                             std::vector<std::string> classNames, const TrainOptions& o) {
  const int classes = static_cast<int>(classNames.size());
  if (features.empty() || features.size() != classIndex.size())
    return fail(Status::BadArgument, "classifier: no samples, or features and labels differ in count");
  if (classes < 2) return fail(Status::BadArgument, "classifier: at least two classes are needed");
  const int n = static_cast<int>(features.size());
  cv::Mat x(n, kFeatureCount, CV_32F), y(n, classes, CV_32F, cv::Scalar(0));
  std::vector<int> count(classes, 0);
  for (int i = 0; i < n; ++i) {
    if (classIndex[i] < 0 || classIndex[i] >= classes) return fail(Status::BadArgument, "classifier: a label is out of range");
    row(features[i]).copyTo(x.row(i));
    y.at<float>(i, classIndex[i]) = 1;
    ++count[classIndex[i]];
  }
  for (int c = 0; c < classes; ++c)
    if (count[c] == 0) return fail(Status::BadArgument, "classifier: class '" + classNames[c] + "' has no samples");

  auto impl = std::make_shared<Impl>();
  impl->names = std::move(classNames);
  impl->hidden = o.hidden;
  // Per-class mean and std (std floored at 5 % of the feature's std over all samples, so a
  // feature constant within a class, e.g. its hole count, still has a finite scale).
  cv::Mat colMean, colStd;
  cv::reduce(x, colMean, 0, cv::REDUCE_AVG);
  cv::Mat diff = x - cv::repeat(colMean, n, 1);
  cv::reduce(diff.mul(diff), colStd, 0, cv::REDUCE_AVG);
  cv::sqrt(colStd, colStd);
  impl->mean = cv::Mat::zeros(classes, kFeatureCount, CV_32F);
  impl->stddev = cv::Mat::zeros(classes, kFeatureCount, CV_32F);
  for (int c = 0; c < classes; ++c) {
    cv::Mat sum = cv::Mat::zeros(1, kFeatureCount, CV_32F), sq = cv::Mat::zeros(1, kFeatureCount, CV_32F);
    for (int i = 0; i < n; ++i)
      if (classIndex[i] == c) sum += x.row(i);
    const cv::Mat m = sum / count[c];
    for (int i = 0; i < n; ++i)
      if (classIndex[i] == c) {
        const cv::Mat d = x.row(i) - m;
        sq += d.mul(d);
      }
    cv::Mat s;
    cv::sqrt(sq / count[c], s);
    for (int k = 0; k < kFeatureCount; ++k)
      s.at<float>(0, k) = std::max(s.at<float>(0, k), 0.05f * colStd.at<float>(0, k) + 1e-6f);
    m.copyTo(impl->mean.row(c));
    s.copyTo(impl->stddev.row(c));
  }

  std::vector<int> layers{kFeatureCount};
  layers.insert(layers.end(), o.hidden.begin(), o.hidden.end());
  layers.push_back(classes);
  impl->mlp = cv::ml::ANN_MLP::create();
  impl->mlp->setLayerSizes(layers);
  impl->mlp->setActivationFunction(cv::ml::ANN_MLP::SIGMOID_SYM, 0, 0);
  // setTrainMethod(RPROP) alone passes param1 = 0 as the initial step dw0: nothing learns
  // (measured: 66.7 % training accuracy, the initial weights). Give OpenCV's documented
  // RPROP defaults explicitly: dw0 = 0.1, dw_min = FLT_EPSILON.
  impl->mlp->setTrainMethod(cv::ml::ANN_MLP::RPROP, 0.1, FLT_EPSILON);
  impl->mlp->setTermCriteria(o.epsilon > 0 ? cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, o.maxIterations, o.epsilon)
                                           : cv::TermCriteria(cv::TermCriteria::MAX_ITER, o.maxIterations, 0));
  cv::theRNG().state = o.seed;  // ANN_MLP draws its initial weights from cv::theRNG()
  if (!impl->mlp->train(cv::ml::TrainData::create(x, cv::ml::ROW_SAMPLE, y)))
    return fail(Status::Internal, "classifier: ANN_MLP training failed");
  PartClassifier out;
  out.impl_ = std::move(impl);
  return out;
}

Result<void> PartClassifier::save(const std::string& path) const {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) return fail(Status::BadArgument, path + ": cannot write the classifier");
    fs << "vgr_classifier" << 1;
    fs << "feature_count" << kFeatureCount;
    fs << "features" << "[";
    for (const char* name : featureNames()) fs << name;
    fs << "]";
    fs << "classes" << "[";
    for (const auto& name : impl_->names) fs << name;
    fs << "]";
    fs << "hidden" << impl_->hidden;
    fs << "class_mean" << impl_->mean;
    fs << "class_std" << impl_->stddev;
    fs << "mlp" << "{";
    impl_->mlp->write(fs);
    fs << "}";
    fs.release();
  } catch (const cv::Exception& e) {
    return fail(Status::BadArgument, path + ": cannot write the classifier: " + e.msg);
  }
  return {};
}

Result<PartClassifier> PartClassifier::load(const std::string& path) {
  if (!std::filesystem::exists(path)) return fail(Status::BadArgument, path + ": no such classifier file");
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened() || fs["vgr_classifier"].empty())
      return fail(Status::BadArgument, path + ": not a vgr classifier (no 'vgr_classifier' key)");
    if (!fs["feature_count"].isInt()) return fail(Status::BadArgument, path + ": no 'feature_count' (an integer) in the classifier");
    const int features = static_cast<int>(fs["feature_count"]);
    if (features != kFeatureCount)
      return fail(Status::BadArgument, path + ": the classifier takes " + std::to_string(features) +
                                           " features, this vgr computes " + std::to_string(kFeatureCount));
    // The same count of other features (another order, another vgr) would be read silently
    // as this vgr's: the names must be this vgr's, in its order.
    std::vector<std::string> names;
    for (const auto& n : fs["features"]) names.push_back(static_cast<std::string>(n));
    const auto& ours = featureNames();
    if (names.size() != ours.size() || !std::equal(names.begin(), names.end(), ours.begin()))
      return fail(Status::BadArgument, path + ": its 'features' are not the " + std::to_string(kFeatureCount) +
                                           " this vgr computes, in its order (" + ours.front() + ", ..., " + ours.back() + ")");
    auto impl = std::make_shared<Impl>();
    for (const auto& n : fs["classes"]) impl->names.push_back(static_cast<std::string>(n));
    fs["hidden"] >> impl->hidden;
    fs["class_mean"] >> impl->mean;
    fs["class_std"] >> impl->stddev;
    const int classes = static_cast<int>(impl->names.size());
    if (classes < 2 || impl->mean.rows != classes || impl->mean.cols != kFeatureCount || impl->stddev.size() != impl->mean.size())
      return fail(Status::BadArgument, path + ": class names and class statistics do not match");
    impl->mlp = cv::ml::ANN_MLP::create();
    impl->mlp->read(fs["mlp"]);
    const cv::Mat layers = impl->mlp->getLayerSizes();
    if (layers.total() < 2 || layers.at<int>(0) != kFeatureCount || layers.at<int>(static_cast<int>(layers.total()) - 1) != classes)
      return fail(Status::BadArgument, path + ": the network's input or output size does not match " +
                                           std::to_string(kFeatureCount) + " features / " + std::to_string(classes) + " classes");
    PartClassifier out;
    out.impl_ = std::move(impl);
    return out;
  } catch (const cv::Exception& e) {
    // e.err is the reason alone (e.msg adds OpenCV's version, source file and function).
    std::string why = e.err;
    std::replace(why.begin(), why.end(), '\n', ' ');
    return fail(Status::BadArgument, path + ": cannot read the classifier: " + why);
  }
}

std::vector<float> PartClassifier::outputs(const FeatureVector& f) const {
  cv::Mat out;
  impl_->mlp->predict(row(f), out);
  return std::vector<float>(out.begin<float>(), out.end<float>());
}

Prediction PartClassifier::predict(const FeatureVector& f, double minConfidence, double maxFeatureZ) const {
  const std::vector<float> o = outputs(f);
  Prediction p;
  double sum = 0, best = -1;
  for (std::size_t c = 0; c < o.size(); ++c) {
    const double v = std::clamp(static_cast<double>(o[c]), 0.0, 1.0);
    sum += v;
    if (v > best) best = v, p.best = static_cast<int>(c) + 1;
  }
  p.confidence = sum > 0 ? best * best / sum : 0;
  const int c = p.best - 1;
  // Not over h2..h7: for symmetric parts they are ~0 and their symlog is noise (part_features.hpp).
  for (int k = 0; k < kFeatureCount; ++k) {
    if (k >= 1 && k <= 6) continue;
    p.featureZ = std::max(p.featureZ, std::abs(f[k] - impl_->mean.at<float>(c, k)) / static_cast<double>(impl_->stddev.at<float>(c, k)));
  }
  const bool novel = maxFeatureZ > 0 && p.featureZ > maxFeatureZ;
  p.label = (p.confidence >= minConfidence && !novel) ? p.best : 0;
  return p;
}

const std::vector<std::string>& PartClassifier::classNames() const { return impl_->names; }

std::string PartClassifier::layersText() const {
  std::string s;
  for (int h : impl_->hidden) {
    if (!s.empty()) s += ',';
    s += std::to_string(h);
  }
  return s;
}

}  // namespace vgr::vision::classify
