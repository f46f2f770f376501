#include "vision/calib/intrinsics.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Dense>
#include <fmt/core.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::calib {
namespace {

double viewRms(const std::vector<cv::Point3f>& obj, const std::vector<cv::Point2f>& img, const cv::Vec3d& rvec,
               const cv::Vec3d& tvec, const cv::Matx33d& k, const cv::Vec<double, 5>& d) {
  std::vector<cv::Point2f> proj;
  cv::projectPoints(obj, rvec, tvec, k, d, proj);
  double s = 0;
  for (std::size_t i = 0; i < img.size(); ++i) {
    const cv::Point2f e = proj[i] - img[i];
    s += e.x * e.x + e.y * e.y;
  }
  return std::sqrt(s / static_cast<double>(img.size()));
}

double tiltDeg(const cv::Vec3d& rvec) {
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  return std::acos(std::min(1.0, std::abs(r(2, 2)))) * 180.0 / M_PI;
}

// Standard deviations of the 9 intrinsics (fx, fy, cx, cy, k1, k2, p1, p2, k3) from the
// Gauss-Newton approximation of the covariance at the solution: sigma^2 (J^T J)^-1 with
// sigma^2 = sum of squared residuals / (2 points - parameters), the per-view extrinsics
// eliminated by the Schur complement. (OpenCV's stdDeviationsIntrinsics comes out ~2x the
// spread measured over random data sets in vgr-bench-calib; this one matches it.)
cv::Vec<double, 9> intrinsicsStdDev(const std::vector<std::vector<cv::Point3f>>& objs,
                                    const std::vector<std::vector<cv::Point2f>>& imgs, const std::vector<cv::Mat>& rv,
                                    const std::vector<cv::Mat>& tv, const cv::Matx33d& k, const cv::Vec<double, 5>& d,
                                    int fixedParams) {
  Eigen::Matrix<double, 9, 9> schur = Eigen::Matrix<double, 9, 9>::Zero();
  double sse = 0;
  std::size_t points = 0;
  for (std::size_t v = 0; v < objs.size(); ++v) {
    std::vector<cv::Point2f> proj;
    cv::Mat jac;  // 2n x (3 rot + 3 trans + 2 f + 2 c + 5 dist)
    cv::projectPoints(objs[v], rv[v], tv[v], k, d, proj, jac);
    const auto n = static_cast<Eigen::Index>(proj.size());
    Eigen::MatrixXd je(2 * n, 6), ji(2 * n, 9);
    for (Eigen::Index r = 0; r < 2 * n; ++r) {
      for (int c = 0; c < 6; ++c) je(r, c) = jac.at<double>(static_cast<int>(r), c);
      for (int c = 0; c < 9; ++c) ji(r, c) = jac.at<double>(static_cast<int>(r), 6 + c);
    }
    const Eigen::Matrix<double, 9, 9> a = ji.transpose() * ji;
    const Eigen::Matrix<double, 9, 6> b = ji.transpose() * je;
    const Eigen::Matrix<double, 6, 6> c = je.transpose() * je;
    schur += a - b * c.ldlt().solve(b.transpose());
    for (std::size_t i = 0; i < proj.size(); ++i) {
      const cv::Point2f e = proj[i] - imgs[v][i];
      sse += e.x * e.x + e.y * e.y;
    }
    points += proj.size();
  }
  // Parameters held fixed (tangential distortion off): drop their rows and columns.
  std::vector<int> freeIdx;
  for (int i = 0; i < 9; ++i)
    if (!(fixedParams & (1 << i))) freeIdx.push_back(i);
  const auto nf = static_cast<Eigen::Index>(freeIdx.size());
  Eigen::MatrixXd sf(nf, nf);
  for (Eigen::Index i = 0; i < nf; ++i)
    for (Eigen::Index j = 0; j < nf; ++j) sf(i, j) = schur(freeIdx[static_cast<std::size_t>(i)], freeIdx[static_cast<std::size_t>(j)]);
  const double dof = static_cast<double>(2 * points) - static_cast<double>(nf + 6 * static_cast<Eigen::Index>(objs.size()));
  const double sigma2 = dof > 0 ? sse / dof : 0;
  const Eigen::MatrixXd cov = sf.inverse() * sigma2;
  cv::Vec<double, 9> out = cv::Vec<double, 9>::all(0);
  for (Eigen::Index i = 0; i < nf; ++i) out[freeIdx[static_cast<std::size_t>(i)]] = std::sqrt(std::max(0.0, cov(i, i)));
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// OpenCV 4.6's predefined ArUco dictionaries by name (cv::aruco::PREDEFINED_DICTIONARY_NAME).
struct DictName {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
  int size;  // markers in the dictionary
};
constexpr DictName kDicts[] = {
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50, 50},       {"DICT_4X4_100", cv::aruco::DICT_4X4_100, 100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250, 250},    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000, 1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50, 50},       {"DICT_5X5_100", cv::aruco::DICT_5X5_100, 100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250, 250},    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000, 1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50, 50},       {"DICT_6X6_100", cv::aruco::DICT_6X6_100, 100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250, 250},    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000, 1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50, 50},       {"DICT_7X7_100", cv::aruco::DICT_7X7_100, 100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250, 250},    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000, 1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL, 1024},
    {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5, 30},
    {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9, 35},
    {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10, 2320},
    {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11, 587},
};

// The OpenCV board: squares = inner corners + 1; markers in the white squares, ids 0..n-1.
struct CharucoBoardInfo {
  cv::Ptr<cv::aruco::CharucoBoard> board;
  // OpenCV's board frame has y up on the printed board in 4.6 (marker corners run clockwise
  // with y decreasing); ours has y down. flipY: plate (x, y) = (X - s, rows s - Y), else
  // (X - s, Y - s). Decided from the marker corner order, not from the version number.
  bool flipY = true;
  std::vector<int> cornerIndex;  // OpenCV chessboard-corner id -> index into patternObjectPoints()
};

cv::Point2f boardToPlate(const CharucoBoardInfo& b, const PatternSpec& s, cv::Point3f p) {
  const auto pitch = static_cast<float>(s.pitchMm);
  return b.flipY ? cv::Point2f(p.x - pitch, static_cast<float>(s.rows) * pitch - p.y)
                 : cv::Point2f(p.x - pitch, p.y - pitch);
}

Result<CharucoBoardInfo> charucoBoard(const PatternSpec& spec) {
  const DictName* dict = nullptr;
  for (const auto& d : kDicts)
    if (spec.dictionary == d.name) dict = &d;
  if (!dict) {
    std::string names;
    for (const auto& d : kDicts) names += (names.empty() ? "" : ", ") + std::string(d.name);
    return fail(Status::BadArgument, fmt::format("--dict '{}': unknown ArUco dictionary; one of {}", spec.dictionary, names));
  }
  const int squares = (spec.cols + 1) * (spec.rows + 1), markers = squares / 2;
  if (markers > dict->size)
    return fail(Status::BadArgument,
                fmt::format("--dict {}: {} markers, a {}x{}-square charuco board (--cols {} --rows {}) needs {}",
                            dict->name, dict->size, spec.cols + 1, spec.rows + 1, spec.cols, spec.rows, markers));
  CharucoBoardInfo b;
  cv::Ptr<cv::aruco::Dictionary> d = cv::aruco::getPredefinedDictionary(dict->id);
  b.board = cv::aruco::CharucoBoard::create(spec.cols + 1, spec.rows + 1, static_cast<float>(spec.pitchMm),
                                            static_cast<float>(spec.markerMm), d);
  const auto& m0 = b.board->objPoints.at(0);
  const cv::Point3f e1 = m0[1] - m0[0], e3 = m0[3] - m0[0];
  b.flipY = e1.x * e3.y - e1.y * e3.x < 0;  // corners clockwise on the print <=> y up in OpenCV's frame
  const auto& cc = b.board->chessboardCorners;
  b.cornerIndex.resize(cc.size());
  for (std::size_t k = 0; k < cc.size(); ++k) {
    const cv::Point2f p = boardToPlate(b, spec, cc[k]);
    const int i = static_cast<int>(std::lround(p.x / spec.pitchMm)), j = static_cast<int>(std::lround(p.y / spec.pitchMm));
    b.cornerIndex[k] = j * spec.cols + i;
  }
  return b;
}

}  // namespace

Result<CharucoLayout> charucoLayout(const PatternSpec& spec) {
  auto b = charucoBoard(spec);
  if (!b) return std::unexpected(b.error());
  CharucoLayout l;
  const int bits = b->board->dictionary->markerSize;
  for (std::size_t m = 0; m < b->board->objPoints.size(); ++m) {
    std::array<cv::Point2f, 4> c;
    for (int k = 0; k < 4; ++k) c[static_cast<std::size_t>(k)] = boardToPlate(*b, spec, b->board->objPoints[m][static_cast<std::size_t>(k)]);
    l.markers.push_back(c);
    cv::Mat img;
    cv::aruco::drawMarker(b->board->dictionary, b->board->ids[m], bits + 2, img, 1);
    l.markerImages.push_back(img);
  }
  return l;
}

Result<PatternKind> parsePatternKind(const std::string& name) {
  if (name == "chessboard") return PatternKind::Chessboard;
  if (name == "circles") return PatternKind::Circles;
  if (name == "charuco") return PatternKind::Charuco;
  return fail(Status::BadArgument, fmt::format("unknown pattern '{}': expected chessboard, circles or charuco", name));
}

const char* patternKindName(PatternKind k) {
  switch (k) {
    case PatternKind::Chessboard: return "chessboard";
    case PatternKind::Circles: return "circles";
    case PatternKind::Charuco: return "charuco";
  }
  return "?";
}

Result<void> validatePatternSpec(const PatternSpec& spec) {
  if (spec.cols < 2 || spec.rows < 2)
    return fail(Status::BadArgument, fmt::format("--cols {} --rows {}: at least 2 each", spec.cols, spec.rows));
  if (!(spec.pitchMm > 0)) return fail(Status::BadArgument, fmt::format("--square {}: must be > 0 mm", spec.pitchMm));
  if (spec.kind != PatternKind::Charuco) return {};
  if (!(spec.markerMm > 0 && spec.markerMm < spec.pitchMm))
    return fail(Status::BadArgument,
                fmt::format("--marker {}: the marker side must be > 0 and smaller than the square ({} mm)", spec.markerMm,
                            spec.pitchMm));
  auto board = charucoBoard(spec);
  if (!board) return std::unexpected(board.error());
  return {};
}

std::vector<cv::Point3f> patternObjectPoints(const PatternSpec& spec) {
  std::vector<cv::Point3f> pts;
  pts.reserve(static_cast<std::size_t>(spec.cols * spec.rows));
  for (int j = 0; j < spec.rows; ++j)
    for (int i = 0; i < spec.cols; ++i)
      pts.emplace_back(static_cast<float>(i * spec.pitchMm), static_cast<float>(j * spec.pitchMm), 0.f);
  return pts;
}

namespace {

// ChArUco detection: the markers, then the chessboard corners between them, each
// interpolated from the local homography of its neighbouring markers and refined with
// cornerSubPix (interpolateCornersCharuco). Works on partial views.
void detectCharuco(const cv::Mat& gray, const PatternSpec& spec, ViewDetection& d) {
  auto b = charucoBoard(spec);
  if (!b) {
    d.note = b.error().message;
    return;
  }
  std::vector<std::vector<cv::Point2f>> markerCorners, rejected;
  std::vector<int> markerIds;
  const cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  cv::aruco::detectMarkers(gray, b->board->dictionary, markerCorners, markerIds, params, rejected);
  if (markerIds.empty()) {
    d.note = fmt::format("no {} marker found", spec.dictionary);
    return;
  }
  // Markers of the dictionary that are not on this board (ids beyond its count): another tag
  // in view -- ignored if the rest fits the board -- or --cols/--rows given as squares
  // instead of inner corners, which the layout check below then refuses.
  const int onBoard = static_cast<int>(b->board->ids.size());
  std::size_t foreign = 0;
  for (std::size_t m = markerIds.size(); m-- > 0;)
    if (markerIds[m] >= onBoard) {
      ++foreign;
      markerIds.erase(markerIds.begin() + static_cast<std::ptrdiff_t>(m));
      markerCorners.erase(markerCorners.begin() + static_cast<std::ptrdiff_t>(m));
    }
  const std::string foreignNote =
      foreign ? fmt::format("; {} marker(s) with ids beyond this board's {} (--cols/--rows count inner corners, i.e. "
                            "squares - 1)",
                            foreign, onBoard)
              : "";
  if (foreign && markerIds.size() < 4) {
    d.note = fmt::format("{} marker(s) of this board, too few to check the layout{}", markerIds.size(), foreignNote);
    return;
  }
  if (!markerIds.empty()) cv::aruco::refineDetectedMarkers(gray, b->board, markerCorners, markerIds, rejected);
  // The markers must sit where this board has them: one homography from the plate to the
  // image explains them to a few px (lens distortion) when --cols/--rows/--square/--marker
  // are right; a different layout with the same ids is off by about a square.
  if (markerIds.size() >= 4) {
    std::vector<cv::Point2f> plate, image;
    double side = 0;
    for (std::size_t m = 0; m < markerIds.size(); ++m) {
      const auto& obj = b->board->objPoints.at(static_cast<std::size_t>(markerIds[m]));
      for (int k = 0; k < 4; ++k) {
        plate.push_back(boardToPlate(*b, spec, obj[static_cast<std::size_t>(k)]));
        image.push_back(markerCorners[m][static_cast<std::size_t>(k)]);
      }
      side += cv::norm(markerCorners[m][1] - markerCorners[m][0]) / static_cast<double>(markerIds.size());
    }
    const cv::Mat h = cv::findHomography(plate, image, 0);
    if (!h.empty()) {
      std::vector<cv::Point2f> mapped;
      cv::perspectiveTransform(plate, mapped, h);
      std::vector<double> res;
      for (std::size_t k = 0; k < mapped.size(); ++k) res.push_back(cv::norm(mapped[k] - image[k]));
      const double med = median(res);
      if (med > std::max(5.0, 0.2 * side)) {
        d.note = fmt::format("the {} markers do not fit a {}x{} board with {} mm squares and {} mm markers (median "
                             "misfit {:.1f} px): check --cols/--rows/--square/--marker{}",
                             markerIds.size(), spec.cols, spec.rows, spec.pitchMm, spec.markerMm, med, foreignNote);
        return;
      }
    }
  }
  if (foreign) d.note = fmt::format("{} marker(s) not on this board ignored", foreign);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  if (cv::aruco::interpolateCornersCharuco(markerCorners, markerIds, gray, b->board, corners, ids) > 0) {
    std::vector<std::pair<int, cv::Point2f>> byIndex;
    for (std::size_t k = 0; k < ids.size(); ++k)
      byIndex.emplace_back(b->cornerIndex.at(static_cast<std::size_t>(ids[k])), corners[k]);
    std::sort(byIndex.begin(), byIndex.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    // OpenCV 4.6 refines these corners with loose settings (0.1 px, 30 iterations, a window
    // from the marker distance): on rendered plates they stay ~0.7 px off. Refine again,
    // like chessboard corners, with a window that stays inside the white gap between the
    // corner and its markers: 60 % of the gap at the local scale (nearest corner distance).
    const double gapShare = (spec.pitchMm - spec.markerMm) / (2 * spec.pitchMm);
    for (std::size_t k = 0; k < byIndex.size(); ++k) {
      double pitchPx = 1e9;
      for (std::size_t m = 0; m < byIndex.size(); ++m)
        if (m != k) pitchPx = std::min<double>(pitchPx, cv::norm(byIndex[m].second - byIndex[k].second));
      const int half = std::clamp(static_cast<int>(0.6 * gapShare * pitchPx), 2, 5);
      cv::Point2f p = byIndex[k].second;
      if (p.x < half + 1 || p.y < half + 1 || p.x > gray.cols - half - 2 || p.y > gray.rows - half - 2) continue;
      std::vector<cv::Point2f> one{p};
      cv::cornerSubPix(gray, one, cv::Size(half, half), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
      if (cv::norm(one[0] - p) > 2.0) continue;  // ran off: not a clean corner (cut by the image border, occluded)
      d.ids.push_back(byIndex[k].first);
      d.corners.push_back(one[0]);
    }
  }
  if (static_cast<int>(d.corners.size()) < kMinCharucoCorners) {
    d.note = fmt::format("{} markers, {} charuco corners (at least {} needed){}", markerIds.size(), d.corners.size(),
                         kMinCharucoCorners, foreignNote);
    return;
  }
  // Corners on one line say nothing about the plate's pose.
  std::set<int> cols, rows;
  for (int i : d.ids) cols.insert(i % spec.cols), rows.insert(i / spec.cols);
  if (cols.size() < 2 || rows.size() < 2) {
    d.note = fmt::format("{} charuco corners, all on one line", d.corners.size());
    return;
  }
  d.found = true;
}

}  // namespace

ViewDetection detectPattern(const cv::Mat& gray, const PatternSpec& spec, const std::string& name) {
  ViewDetection d;
  d.name = name;
  const cv::Size size(spec.cols, spec.rows);
  if (spec.kind == PatternKind::Chessboard) {
    d.found = cv::findChessboardCorners(gray, size, d.corners,
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (d.found)
      cv::cornerSubPix(gray, d.corners, cv::Size(5, 5), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  } else if (spec.kind == PatternKind::Circles) {
    d.found = cv::findCirclesGrid(gray, size, d.corners, cv::CALIB_CB_SYMMETRIC_GRID);
  } else {
    detectCharuco(gray, spec, d);
  }
  if (!d.found) {
    d.corners.clear();
    d.ids.clear();
  }
  return d;
}

Result<IntrinsicsResult> calibrateIntrinsics(const std::vector<ViewDetection>& views, const PatternSpec& spec,
                                             cv::Size imageSize, const IntrinsicsOptions& options) {
  const std::vector<cv::Point3f> obj = patternObjectPoints(spec);
  std::vector<const ViewDetection*> usable;
  std::vector<std::vector<cv::Point3f>> usableObj;  // object points of each usable view
  std::vector<std::string> missing;
  for (const auto& v : views) {
    if (!v.found) {
      missing.push_back(v.note.empty() ? v.name : fmt::format("{} ({})", v.name, v.note));
      continue;
    }
    std::vector<cv::Point3f> o;
    if (v.ids.empty()) {
      if (v.corners.size() != obj.size())
        return fail(Status::BadArgument, fmt::format("view '{}': {} points detected, the {}x{} pattern has {}", v.name,
                                                     v.corners.size(), spec.cols, spec.rows, obj.size()));
      o = obj;
    } else {
      if (v.ids.size() != v.corners.size())
        return fail(Status::BadArgument,
                    fmt::format("view '{}': {} point ids for {} points", v.name, v.ids.size(), v.corners.size()));
      for (int id : v.ids) {
        if (id < 0 || id >= static_cast<int>(obj.size()))
          return fail(Status::BadArgument, fmt::format("view '{}': point id {} outside the {}x{} pattern", v.name, id,
                                                       spec.cols, spec.rows));
        o.push_back(obj[static_cast<std::size_t>(id)]);
      }
      if (o.size() < 6)
        return fail(Status::BadArgument,
                    fmt::format("view '{}': {} points, at least 6 needed per view", v.name, o.size()));
    }
    usable.push_back(&v);
    usableObj.push_back(std::move(o));
  }
  if (static_cast<int>(usable.size()) < options.minViews) {
    std::string list;
    for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
    return fail(Status::BadArgument,
                fmt::format("too few views: the {} {}x{} was found in {} of {} views, {} needed{}{}",
                            patternKindName(spec.kind), spec.cols, spec.rows, usable.size(), views.size(),
                            options.minViews, missing.empty() ? "" : "; not found in: ", list));
  }

  IntrinsicsResult res;
  std::vector<bool> active(usable.size(), true);
  for (int round = 0; round < 5; ++round) {
    std::vector<std::vector<cv::Point3f>> objs;
    std::vector<std::vector<cv::Point2f>> imgs;
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < usable.size(); ++i)
      if (active[i]) {
        objs.push_back(usableObj[i]);
        imgs.push_back(usable[i]->corners);
        idx.push_back(i);
      }
    cv::Mat k, d;
    std::vector<cv::Mat> rv, tv;
    try {
      res.camera.rmsPx = cv::calibrateCamera(objs, imgs, imageSize, k, d, rv, tv,
                                             options.tangential ? 0 : cv::CALIB_ZERO_TANGENT_DIST,
                                             cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
    } catch (const cv::Exception& e) {
      return fail(Status::BadArgument, fmt::format("calibrateCamera failed on {} views: {}", idx.size(), e.what()));
    }
    res.camera.cameraMatrix = cv::Matx33d(k);
    for (int c = 0; c < 5; ++c) res.camera.dist[c] = d.at<double>(c);
    res.camera.tangential = options.tangential;
    res.camera.stdDev = intrinsicsStdDev(objs, imgs, rv, tv, res.camera.cameraMatrix, res.camera.dist,
                                         options.tangential ? 0 : (1 << 6) | (1 << 7));
    res.camera.imageSize = imageSize;
    res.camera.views.clear();
    res.rvecs.clear();
    res.tvecs.clear();
    res.usedViews.clear();
    std::vector<double> errs;
    for (std::size_t n = 0; n < idx.size(); ++n) {
      const cv::Vec3d r(rv[n]), t(tv[n]);
      const double e = viewRms(objs[n], imgs[n], r, t, res.camera.cameraMatrix, res.camera.dist);
      errs.push_back(e);
      res.camera.views.push_back({usable[idx[n]]->name, e, tiltDeg(r), true});
      res.rvecs.push_back(r);
      res.tvecs.push_back(t);
      res.usedViews.push_back(usable[idx[n]]->name);
    }
    // Outliers: views far above the median error. Remove the worst one per round and re-solve
    // (removing all at once can throw away good views that a single bad one dragged up).
    const double limit = std::max(options.outlierFactor * median(errs), options.outlierFloorPx);
    std::size_t worst = 0;
    for (std::size_t n = 1; n < errs.size(); ++n)
      if (errs[n] > errs[worst]) worst = n;
    if (errs[worst] <= limit || static_cast<int>(idx.size()) <= options.minViews) break;
    active[idx[worst]] = false;
    res.rejectedViews.push_back(fmt::format("{} ({:.3f} px > {:.3f} px)", usable[idx[worst]]->name, errs[worst], limit));
  }
  for (std::size_t i = 0; i < usable.size(); ++i)
    if (!active[i]) res.camera.views.push_back({usable[i]->name, -1, 0, false});

  // Coverage: which cells of an 8 x 8 image grid hold a corner of some used view.
  bool cells[8][8] = {};
  for (std::size_t i = 0; i < usable.size(); ++i) {
    if (!active[i]) continue;
    for (const auto& p : usable[i]->corners) {
      const int cx = std::clamp(static_cast<int>(p.x * 8 / imageSize.width), 0, 7);
      const int cy = std::clamp(static_cast<int>(p.y * 8 / imageSize.height), 0, 7);
      cells[cy][cx] = true;
    }
  }
  int filled = 0;
  for (auto& row : cells)
    for (bool c : row) filled += c;
  auto& cov = res.coverage;
  cov.imageCoverage = filled / 64.0;
  cov.minTiltDeg = 90;
  cov.maxTiltDeg = 0;
  for (const auto& v : res.camera.views)
    if (v.used) cov.minTiltDeg = std::min(cov.minTiltDeg, v.tiltDeg), cov.maxTiltDeg = std::max(cov.maxTiltDeg, v.tiltDeg);
  if (cov.imageCoverage < 0.6)
    cov.advice.push_back(fmt::format("corners cover {:.0f} % of the image: add views with the plate near the "
                                     "corners and edges (distortion is largest there)",
                                     cov.imageCoverage * 100));
  if (cov.maxTiltDeg < 20)
    cov.advice.push_back(fmt::format("largest plate tilt is {:.1f} deg: add views tilted 20-45 deg (focal length "
                                     "is poorly determined from fronto-parallel views)",
                                     cov.maxTiltDeg));
  if (res.usedViews.size() < 10)
    cov.advice.push_back(fmt::format("{} views used: 10-20 are recommended", res.usedViews.size()));
  // How well the data pin the parameters down: 3 standard deviations against the tolerances.
  const auto& sd = res.camera.stdDev;
  if (3 * std::max(sd[2], sd[3]) > options.principalPointTolPx)
    cov.advice.push_back(fmt::format(
        "principal point poorly determined: std dev cx {:.2f} px, cy {:.2f} px (3 std dev > {:.2f} px): it needs many "
        "corners far out in the image corners -- add views with the plate there, tilted about both axes, use a plate "
        "with more corners, or a ChArUco plate filling the frame{}",
        sd[2], sd[3], options.principalPointTolPx,
        options.tangential ? "; it trades off against the tangential distortion" : ""));
  if (3 * std::max(sd[0] / res.camera.fx(), sd[1] / res.camera.fy()) > options.focalTolRel)
    cov.advice.push_back(fmt::format("focal length poorly determined: std dev fx {:.3f} %, fy {:.3f} %: add views tilted "
                                     "20-45 deg",
                                     100 * sd[0] / res.camera.fx(), 100 * sd[1] / res.camera.fy()));
  if (options.tangential) {
    cov.p1Sigmas = sd[6] > 0 ? std::abs(res.camera.dist[2]) / sd[6] : 0;
    cov.p2Sigmas = sd[7] > 0 ? std::abs(res.camera.dist[3]) / sd[7] : 0;
  }
  return res;
}

}  // namespace vgr::vision::calib
