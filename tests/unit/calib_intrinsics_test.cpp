// Intrinsics on synthetic plates with known camera (sim/calib_scene): accuracy against the
// truth, outlier rejection, bad input, and the YAML file.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "sim/calib_scene.hpp"
#include "vision/calib/intrinsics.hpp"

namespace {

using namespace vgr;
using vision::calib::PatternKind;
using vision::calib::PatternSpec;
using vision::calib::ViewDetection;

std::vector<ViewDetection> cornerViews(const sim::TrueCamera& cam, const PatternSpec& spec, int n, double sigma,
                                       std::uint64_t seed, double distanceMm = 450, double maxTiltDeg = 35,
                                       double partialShare = 0) {
  std::vector<ViewDetection> views;
  const auto poses = sim::randomPlateViews(cam, spec, n, seed, distanceMm, maxTiltDeg, 25, partialShare);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::string name = "view" + std::to_string(i);
    if (partialShare > 0) {  // the corners a charuco detector would return, with their ids
      ViewDetection v = sim::visiblePattern(cam, spec, poses[i], 10, name);
      v.corners = sim::addCornerNoise(v.corners, sigma, seed * 100 + i);
      views.push_back(v);
      continue;
    }
    ViewDetection v;
    v.name = name;
    v.found = true;
    v.corners = sim::addCornerNoise(sim::projectPattern(cam, spec, poses[i]), sigma, seed * 100 + i);
    views.push_back(v);
  }
  return views;
}

void expectCloseToTruth(const vision::calib::CameraIntrinsics& c, const sim::TrueCamera& t, const std::string& what) {
  // The accuracy bound of docs/calibration.md: focal within 0.1 %, principal point within 0.5 px.
  EXPECT_LT(std::abs(c.fx() / t.cameraMatrix(0, 0) - 1), 0.001) << what << ": fx " << c.fx();
  EXPECT_LT(std::abs(c.fy() / t.cameraMatrix(1, 1) - 1), 0.001) << what << ": fy " << c.fy();
  EXPECT_LT(std::abs(c.cx() - t.cameraMatrix(0, 2)), 0.5) << what << ": cx " << c.cx();
  EXPECT_LT(std::abs(c.cy() - t.cameraMatrix(1, 2)), 0.5) << what << ": cy " << c.cy();
}

bool advises(const vision::calib::IntrinsicsResult& r, const std::string& what) {
  for (const auto& a : r.coverage.advice)
    if (a.find(what) != std::string::npos) return true;
  return false;
}

// The two plates and view designs that meet the done-when bar (docs/calibration.md, table
// made by vgr-bench-calib: every one of 20 seeds within it).
PatternSpec denseChessboard() { return {PatternKind::Chessboard, 21, 15, 10.0}; }
PatternSpec charucoBoard() {
  PatternSpec s{PatternKind::Charuco, 15, 11, 15.0};
  s.markerMm = 11;
  return s;
}

// The accuracy target of docs/calibration.md: 0.1 px corner noise, realistic distortion (including tangential).
// The principal point is the weakest parameter: it trades off against the tangential
// distortion, and what pins it down is many corners far out in the image corners. The
// standard deviation calibrateIntrinsics reports is ~0.3-0.4 px for 30 views of an 11x8
// board (so 0.5 px is met by most, not all, random sets); a dense 21x15 chessboard seen 60
// times, or a ChArUco board filling the frame in 40 views, brings it to ~0.12-0.15 px.
// Several seeds each; the bench runs 20.
TEST(calib_intrinsics, corners_with_0p1px_noise_meet_the_bound) {
  const auto cam = sim::defaultCalibCamera();
  for (std::uint64_t seed : {1, 2, 3}) {
    const auto spec = denseChessboard();
    const auto views = cornerViews(cam, spec, 60, 0.1, seed, 400, 40);
    ASSERT_EQ(views.size(), 60u);
    auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
    ASSERT_TRUE(r) << r.error().message;
    expectCloseToTruth(r->camera, cam, "chessboard 21x15, seed " + std::to_string(seed));
    EXPECT_NEAR(r->camera.rmsPx, 0.1 * std::sqrt(2.0), 0.02);  // RMS of the 2-D error
    EXPECT_TRUE(r->rejectedViews.empty());
    EXPECT_GT(r->coverage.imageCoverage, 0.6);
    EXPECT_FALSE(advises(*r, "principal point poorly determined")) << "seed " << seed;
  }
  for (std::uint64_t seed : {1, 2, 3}) {
    const auto spec = charucoBoard();
    const auto views = cornerViews(cam, spec, 40, 0.1, seed, 250, 40, 1.0);
    ASSERT_EQ(views.size(), 40u);
    std::size_t partial = 0;
    for (const auto& v : views) partial += v.corners.size() < static_cast<std::size_t>(spec.cols * spec.rows);
    EXPECT_GT(partial, 30u) << "frame-filling views: the plate sticks out of the image";
    auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
    ASSERT_TRUE(r) << r.error().message;
    expectCloseToTruth(r->camera, cam, "charuco 15x11, seed " + std::to_string(seed));
    EXPECT_NEAR(r->camera.rmsPx, 0.1 * std::sqrt(2.0), 0.02);
    EXPECT_FALSE(advises(*r, "principal point poorly determined")) << "seed " << seed;
  }
}

// The reported standard deviations follow the data: a thin data set is flagged, and the
// principal point's std dev is in line with its actual error.
TEST(calib_intrinsics, a_poorly_determined_principal_point_is_reported) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  auto r = vision::calib::calibrateIntrinsics(cornerViews(cam, spec, 15, 0.1, 1), spec, cam.imageSize);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(advises(*r, "principal point poorly determined")) << "15 views of a 9x6 board";
  // 15 views of a 9x6 board: std dev ~1 px (vgr-bench-calib: 1.2 / 0.9 px predicted, 1.0 /
  // 1.1 px RMS actual over seeds). Loosely: between 0.3 and 3 px, and the actual error
  // within 4 std dev.
  for (int i : {2, 3}) {
    EXPECT_GT(r->camera.stdDev[i], 0.3);
    EXPECT_LT(r->camera.stdDev[i], 3.0);
  }
  EXPECT_LT(std::abs(r->camera.cx() - cam.cameraMatrix(0, 2)), 4 * r->camera.stdDev[2]);
  EXPECT_LT(std::abs(r->camera.cy() - cam.cameraMatrix(1, 2)), 4 * r->camera.stdDev[3]);
  // p1, p2 of the synthetic lens are far from 0 in std dev units: not to be dropped.
  auto good = vision::calib::calibrateIntrinsics(cornerViews(cam, denseChessboard(), 60, 0.1, 1, 400, 40),
                                                 denseChessboard(), cam.imageSize);
  ASSERT_TRUE(good);
  EXPECT_GT(std::min(good->coverage.p1Sigmas, good->coverage.p2Sigmas), 3.0);
  // Tangential distortion held at 0 on a lens that has some: the solve is precise (small std
  // dev) but biased -- why it is not the default.
  vision::calib::IntrinsicsOptions noTan;
  noTan.tangential = false;
  auto biased = vision::calib::calibrateIntrinsics(cornerViews(cam, denseChessboard(), 60, 0.1, 1, 400, 40),
                                                   denseChessboard(), cam.imageSize, noTan);
  ASSERT_TRUE(biased);
  EXPECT_EQ(biased->camera.dist[2], 0.0);
  EXPECT_EQ(biased->camera.stdDev[6], 0.0);
  EXPECT_GT(std::hypot(biased->camera.cx() - cam.cameraMatrix(0, 2), biased->camera.cy() - cam.cameraMatrix(1, 2)), 0.5);
}

TEST(calib_intrinsics, rendered_chessboard_images_are_detected_and_calibrate) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  const auto poses = sim::randomPlateViews(cam, spec, 12, 2);
  std::vector<ViewDetection> views;
  double maxErr = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sim::PlateRenderOptions o;
    o.seed = i;
    const cv::Mat img = sim::renderPlate(cam, spec, poses[i], o);
    views.push_back(vision::calib::detectPattern(img, spec, "img" + std::to_string(i)));
    ASSERT_TRUE(views.back().found) << "view " << i;
    const auto truth = sim::projectPattern(cam, spec, poses[i]);
    for (std::size_t j = 0; j < truth.size(); ++j)
      maxErr = std::max<double>(maxErr, cv::norm(truth[j] - views.back().corners[j]));
  }
  // The detector on the rendered plates (1 gray level noise): worst corner vs truth.
  EXPECT_LT(maxErr, 0.3) << "detected corners vs rendered truth";
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_TRUE(r) << r.error().message;
  // 12 views keep this test fast; at 12 views the principal point's statistical spread is
  // ~1 px (see the corner-level test for the done-when bound), so this checks the pipeline.
  EXPECT_LT(std::abs(r->camera.fx() / cam.cameraMatrix(0, 0) - 1), 0.003);
  EXPECT_LT(std::abs(r->camera.cx() - cam.cameraMatrix(0, 2)), 2.0);
  EXPECT_LT(std::abs(r->camera.cy() - cam.cameraMatrix(1, 2)), 2.0);
  EXPECT_LT(r->camera.rmsPx, 0.2);
}

TEST(calib_intrinsics, rendered_circle_grid_is_found_and_calibrates) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Circles, 7, 5, 25.0};
  const auto poses = sim::randomPlateViews(cam, spec, 10, 3);
  std::vector<ViewDetection> views;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sim::PlateRenderOptions o;
    o.seed = 50 + i;
    views.push_back(vision::calib::detectPattern(sim::renderPlate(cam, spec, poses[i], o), spec, "circles" + std::to_string(i)));
    ASSERT_TRUE(views.back().found) << "view " << i;
  }
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_TRUE(r) << r.error().message;
  // Blob centroids are not the projected circle centres under perspective (a known bias that
  // grows with tilt), so the bound here is looser than for the chessboard: 0.5 % and 2 px.
  EXPECT_LT(std::abs(r->camera.fx() / cam.cameraMatrix(0, 0) - 1), 0.005);
  EXPECT_LT(std::abs(r->camera.cx() - cam.cameraMatrix(0, 2)), 2.0);
}

// ChArUco end to end on rendered images: the plate drawn from OpenCV's board layout, seen
// through the distorted camera, most views with part of the plate outside the image; the
// detector's corners against the rendered truth (by id), then the done-when bar.
TEST(calib_intrinsics, rendered_charuco_views_with_partial_plates_meet_the_bound) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec = charucoBoard();
  const auto poses = sim::randomPlateViews(cam, spec, 40, 7, 250, 40, 25, 1.0);
  ASSERT_EQ(poses.size(), 40u);
  std::vector<ViewDetection> views;
  double maxErr = 0, sumSq = 0;
  std::size_t partial = 0, missed = 0, inner = 0, corners = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sim::PlateRenderOptions o;
    o.seed = 300 + i;
    const cv::Mat img = sim::renderPlate(cam, spec, poses[i], o);
    views.push_back(vision::calib::detectPattern(img, spec, "charuco" + std::to_string(i)));
    const auto& d = views.back();
    ASSERT_TRUE(d.found) << "view " << i << ": " << d.note;
    ASSERT_EQ(d.ids.size(), d.corners.size());
    const auto truth = sim::projectPattern(cam, spec, poses[i]);
    for (std::size_t j = 0; j < d.ids.size(); ++j) {
      const double e = cv::norm(truth[static_cast<std::size_t>(d.ids[j])] - d.corners[j]);
      maxErr = std::max(maxErr, e);
      sumSq += e * e;
      ++corners;
    }
    partial += d.ids.size() < static_cast<std::size_t>(spec.cols * spec.rows);
    // Corners well inside the image and between two markers the detector should not miss.
    const auto seen = sim::visiblePattern(cam, spec, poses[i], 40, "");
    for (int id : seen.ids) missed += !std::binary_search(d.ids.begin(), d.ids.end(), id);
    inner += seen.ids.size();
  }
  EXPECT_GT(partial, 30u) << "views with the plate partly outside the image";
  // Measured: worst corner 0.30 px, RMS 0.0x px (1 gray level noise, tilts up to 40 deg);
  // ~95 % of the corners 40 px inside the image are returned (the others have a marker cut
  // by the border: interpolateCornersCharuco wants two markers next to a corner).
  std::printf("charuco corners: %zu, worst %.3f px, rms %.3f px; %zu of %zu corners 40 px inside the image missed\n",
              corners, maxErr, std::sqrt(sumSq / static_cast<double>(corners)), missed, inner);
  EXPECT_LT(maxErr, 0.4) << "detected charuco corners vs rendered truth, px";
  EXPECT_LT(std::sqrt(sumSq / static_cast<double>(corners)), 0.1) << "RMS of the detected charuco corners, px";
  EXPECT_LT(static_cast<double>(missed), 0.1 * static_cast<double>(inner)) << "corners well inside the image not returned";
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_TRUE(r) << r.error().message;
  expectCloseToTruth(r->camera, cam, "rendered charuco");
  EXPECT_LT(r->camera.rmsPx, 0.15);
  EXPECT_TRUE(r->rejectedViews.empty());
}

TEST(calib_intrinsics, charuco_bad_input_is_named) {
  const auto cam = sim::defaultCalibCamera();
  PatternSpec spec{PatternKind::Charuco, 11, 8, 20.0};
  spec.markerMm = 15;
  // A blank image and a chessboard: no marker, with the reason.
  const cv::Mat blank(600, 800, CV_8UC1, cv::Scalar(120));
  auto d = vision::calib::detectPattern(blank, spec, "blank.png");
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.note.find("no DICT_5X5_100 marker"), std::string::npos) << d.note;
  const PatternSpec chess{PatternKind::Chessboard, 11, 8, 20.0};
  const auto pose = sim::randomPlateViews(cam, chess, 1, 3, 400, 20)[0];
  sim::PlateRenderOptions o;
  const cv::Mat chessImg = sim::renderPlate(cam, chess, pose, o);
  EXPECT_FALSE(vision::calib::detectPattern(chessImg, spec, "chess.png").found);
  // The right board searched with another dictionary: not found.
  const cv::Mat charucoImg = sim::renderPlate(cam, spec, pose, o);
  EXPECT_TRUE(vision::calib::detectPattern(charucoImg, spec, "ok.png").found);
  PatternSpec otherDict = spec;
  otherDict.dictionary = "DICT_6X6_250";
  EXPECT_FALSE(vision::calib::detectPattern(charucoImg, otherDict, "dict.png").found);
  // --cols/--rows given as squares of a smaller board: ids beyond the board, said so.
  PatternSpec smaller = spec;
  smaller.cols = 7;
  smaller.rows = 5;
  const auto s = vision::calib::detectPattern(charucoImg, smaller, "small.png");
  EXPECT_FALSE(s.found);
  EXPECT_NE(s.note.find("ids beyond this board"), std::string::npos) << s.note;
  // Another tag of the dictionary in view (marker 80, beyond this board's 54): ignored.
  {
    PatternSpec big = spec;
    big.cols = 15;
    big.rows = 11;
    auto layout = vision::calib::charucoLayout(big);
    ASSERT_TRUE(layout) << layout.error().message;
    cv::Mat tag;
    cv::resize(layout->markerImages.at(80), tag, cv::Size(70, 70), 0, 0, cv::INTER_NEAREST);
    cv::copyMakeBorder(tag, tag, 12, 12, 12, 12, cv::BORDER_CONSTANT, cv::Scalar(255));
    // The image corner farthest from the plate.
    const auto pts = sim::projectPattern(cam, spec, pose);
    cv::Point best;
    double bestDist = -1;
    for (cv::Point c : {cv::Point(0, 0), cv::Point(800 - tag.cols, 0), cv::Point(0, 600 - tag.rows),
                        cv::Point(800 - tag.cols, 600 - tag.rows)}) {
      double dmin = 1e9;
      for (const auto& q : pts) dmin = std::min<double>(dmin, cv::norm(cv::Point2f(c) + cv::Point2f(47, 47) - q));
      if (dmin > bestDist) bestDist = dmin, best = c;
    }
    cv::Mat withTag = charucoImg.clone();
    tag.copyTo(withTag(cv::Rect(best, tag.size())));
    const auto t = vision::calib::detectPattern(withTag, spec, "tag.png");
    EXPECT_TRUE(t.found) << t.note;
    EXPECT_NE(t.note.find("1 marker(s) not on this board ignored"), std::string::npos) << t.note;
  }
  // A wider board: the same marker ids, elsewhere; the layout check refuses it.
  PatternSpec wider = spec;
  wider.cols = 13;
  const auto w = vision::calib::detectPattern(charucoImg, wider, "wide.png");
  EXPECT_FALSE(w.found);
  EXPECT_NE(w.note.find("do not fit a 13x8 board"), std::string::npos) << w.note;
  // Never found in any view: the error lists every view with its reason.
  std::vector<ViewDetection> none{vision::calib::detectPattern(blank, spec, "a.png"),
                                  vision::calib::detectPattern(chessImg, spec, "b.png")};
  auto r = vision::calib::calibrateIntrinsics(none, spec, cam.imageSize);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("a.png (no DICT_5X5_100 marker found)"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("b.png"), std::string::npos) << r.error().message;
  // Spec errors name the value.
  PatternSpec badDict = spec;
  badDict.dictionary = "DICT_9X9_7";
  auto v = vision::calib::validatePatternSpec(badDict);
  ASSERT_FALSE(v);
  EXPECT_NE(v.error().message.find("DICT_9X9_7"), std::string::npos);
  PatternSpec bigMarker = spec;
  bigMarker.markerMm = 20;
  EXPECT_FALSE(vision::calib::validatePatternSpec(bigMarker));
  PatternSpec tooMany = spec;
  tooMany.dictionary = "DICT_4X4_50";  // 12 x 9 squares need 54 markers
  auto t = vision::calib::validatePatternSpec(tooMany);
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().message.find("needs 54"), std::string::npos) << t.error().message;
  // A partial view's ids that do not belong to the pattern.
  auto views = cornerViews(cam, spec, 6, 0.1, 9, 300, 30, 1.0);
  views[3].ids[0] = 500;
  auto bad = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("view3"), std::string::npos) << bad.error().message;
}

TEST(calib_intrinsics, a_bad_view_is_rejected_and_named) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  auto views = cornerViews(cam, spec, 12, 0.1, 4);
  for (std::size_t j = 0; j < 10; ++j) views[5].corners[j].x += 4.0f;  // a mis-detected view
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_TRUE(r) << r.error().message;
  ASSERT_EQ(r->rejectedViews.size(), 1u);
  EXPECT_NE(r->rejectedViews[0].find("view5"), std::string::npos);
  EXPECT_LT(r->camera.rmsPx, 0.2);  // back to the noise level after the re-solve
}

TEST(calib_intrinsics, too_few_views_names_those_without_the_pattern) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  auto views = cornerViews(cam, spec, 5, 0.1, 5);
  views[1].found = false;
  views[3].found = false;
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Status::BadArgument);
  EXPECT_NE(r.error().message.find("too few views"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("view1, view3"), std::string::npos) << r.error().message;
}

TEST(calib_intrinsics, pattern_never_found_in_a_blank_image) {
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  const cv::Mat blank(600, 800, CV_8UC1, cv::Scalar(120));
  EXPECT_FALSE(vision::calib::detectPattern(blank, spec, "blank.png").found);
  const PatternSpec circles{PatternKind::Circles, 7, 5, 25.0};
  EXPECT_FALSE(vision::calib::detectPattern(blank, circles, "blank.png").found);
}

TEST(calib_intrinsics, point_count_mismatch_names_the_view) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  auto views = cornerViews(cam, spec, 6, 0.1, 6);
  views[2].corners.pop_back();
  auto r = vision::calib::calibrateIntrinsics(views, spec, cam.imageSize);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("view2"), std::string::npos) << r.error().message;
}

TEST(calib_intrinsics, yaml_round_trip_and_bad_files) {
  const auto cam = sim::defaultCalibCamera();
  const PatternSpec spec{PatternKind::Chessboard, 9, 6, 20.0};
  auto r = vision::calib::calibrateIntrinsics(cornerViews(cam, spec, 8, 0.1, 7), spec, cam.imageSize);
  ASSERT_TRUE(r);
  const auto dir = std::filesystem::temp_directory_path() / ("vgr-calib-intr-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "intrinsics.yaml").string();
  ASSERT_TRUE(vision::calib::writeIntrinsics(path, r->camera));
  auto back = vision::calib::readIntrinsics(path);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_DOUBLE_EQ(back->fx(), r->camera.fx());
  EXPECT_DOUBLE_EQ(back->dist[0], r->camera.dist[0]);
  EXPECT_EQ(back->imageSize, cam.imageSize);
  EXPECT_EQ(back->views.size(), r->camera.views.size());
  EXPECT_DOUBLE_EQ(back->rmsPx, r->camera.rmsPx);

  auto missing = vision::calib::readIntrinsics((dir / "nope.yaml").string());
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Status::NotCalibrated);
  EXPECT_NE(missing.error().message.find("nope.yaml"), std::string::npos);
  {
    FILE* f = std::fopen((dir / "bad.yaml").c_str(), "w");
    std::fputs("%YAML:1.0\n---\nimage_width: 800\n", f);
    std::fclose(f);
  }
  auto bad = vision::calib::readIntrinsics((dir / "bad.yaml").string());
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("camera_matrix"), std::string::npos) << bad.error().message;
  // A number too large for a double reads as infinite (found by fuzz_calib_files: cx
  // 6.4e+2607 loaded): refused, naming the key.
  {
    FILE* f = std::fopen((dir / "inf.yaml").c_str(), "w");
    std::fputs("%YAML:1.0\n---\nimage_width: 1280\nimage_height: 1024\n"
               "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
               "   data: [ 1000., 0., 6.4e+2607, 0., 1000., 512., 0., 0., 1. ]\n"
               "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
               "   data: [ 0., 0., 0., 0., 0. ]\n", f);
    std::fclose(f);
  }
  auto inf = vision::calib::readIntrinsics((dir / "inf.yaml").string());
  ASSERT_FALSE(inf) << "cx = " << inf->cx();
  EXPECT_EQ(inf.error().code, Status::NotCalibrated);
  EXPECT_NE(inf.error().message.find("'camera_matrix': value 3 is not a finite number"), std::string::npos) << inf.error().message;
  std::filesystem::remove_all(dir);
}

}  // namespace
