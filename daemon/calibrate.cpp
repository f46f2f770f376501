#include "daemon/calibrate.hpp"

#include <glob.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "sim/calib_scene.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/robot_pose_file.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::daemon {
namespace calib = vision::calib;
namespace se3 = vision::se3;
namespace fs = std::filesystem;

namespace {

Result<calib::PatternSpec> patternSpec(const CalibPatternOptions& o) {
  auto kind = calib::parsePatternKind(o.pattern);
  if (!kind) return std::unexpected(kind.error());
  calib::PatternSpec spec{*kind, o.cols, o.rows, o.squareMm};
  spec.markerMm = o.markerMm > 0 ? o.markerMm : 0.75 * o.squareMm;
  spec.dictionary = o.dictionary;
  if (auto v = calib::validatePatternSpec(spec); !v) return std::unexpected(v.error());
  return spec;
}

// Object points of a detection: all (patternObjectPoints order) or those its ids name (charuco).
std::vector<cv::Point3f> viewObjectPoints(const calib::PatternSpec& spec, const calib::ViewDetection& d) {
  const auto obj = calib::patternObjectPoints(spec);
  if (d.ids.empty()) return obj;
  std::vector<cv::Point3f> o;
  for (int i : d.ids) o.push_back(obj[static_cast<std::size_t>(i)]);
  return o;
}

std::string joinNames(const std::vector<std::string>& names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  return list;
}

// One progress line per image on stderr: "[#####-----]  5/10 name: status".
void progress(std::size_t i, std::size_t n, const std::string& name, const std::string& status) {
  const int width = 20;
  const int done = static_cast<int>(static_cast<double>(i) * width / static_cast<double>(std::max<std::size_t>(n, 1)));
  std::fprintf(stderr, "[%s%s] %3zu/%zu %s: %s\n", std::string(static_cast<std::size_t>(done), '#').c_str(),
               std::string(static_cast<std::size_t>(width - done), '-').c_str(), i, n, name.c_str(), status.c_str());
}

int bad(const std::string& msg) {
  std::fprintf(stderr, "vgr calibrate: %s\n", msg.c_str());
  return 2;
}

}  // namespace

int runCalibrateIntrinsics(const CalibIntrinsicsOptions& o) {
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  glob_t g{};
  const int grc = ::glob(o.images.c_str(), 0, nullptr, &g);
  std::vector<std::string> files;
  for (std::size_t i = 0; grc == 0 && i < g.gl_pathc; ++i) files.emplace_back(g.gl_pathv[i]);
  ::globfree(&g);
  if (files.empty()) return bad(fmt::format("--images '{}': no file matches", o.images));
  std::sort(files.begin(), files.end());

  std::vector<calib::ViewDetection> views;
  cv::Size size;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string name = fs::path(files[i]).filename().string();
    const cv::Mat img = cv::imread(files[i], cv::IMREAD_GRAYSCALE);
    if (img.empty()) return bad(fmt::format("{}: cannot read the image", files[i]));
    if (size.width == 0) size = img.size();
    if (img.size() != size)
      return bad(fmt::format("{}: {}x{} px, the first image is {}x{} px (one camera, one size)", files[i], img.cols,
                             img.rows, size.width, size.height));
    views.push_back(calib::detectPattern(img, *spec, name));
    const auto& d = views.back();
    progress(i + 1, files.size(), name,
             d.found ? fmt::format("found {} points{}{}", d.corners.size(),
                                   d.ids.size() && d.ids.size() < static_cast<std::size_t>(spec->cols * spec->rows)
                                       ? fmt::format(" of {} (partial view)", spec->cols * spec->rows)
                                       : "",
                                   d.note.empty() ? "" : "; " + d.note)
                     : "pattern NOT found" + (d.note.empty() ? "" : ": " + d.note));
  }
  std::vector<std::string> notFound;
  for (const auto& v : views)
    if (!v.found) notFound.push_back(v.name);
  if (notFound.size() == views.size())
    return bad(fmt::format("too few views: the {} {}x{} was found in none of the {} images ({}){}", calib::patternKindName(spec->kind),
                           spec->cols, spec->rows, views.size(), joinNames(notFound),
                           spec->kind == calib::PatternKind::Charuco
                               ? fmt::format(": check --dict (now {}), --cols/--rows (inner corners = squares - 1) and "
                                             "--square/--marker",
                                             spec->dictionary)
                               : ""));
  calib::IntrinsicsOptions io;
  io.tangential = !o.noTangential;
  auto r = calib::calibrateIntrinsics(views, *spec, size, io);
  if (!r) return bad(r.error().message);
  const auto& c = r->camera;
  std::printf("per-view reprojection error (px):\n");
  for (const auto& v : c.views)
    if (v.used) std::printf("  %-32s %7.3f   tilt %5.1f deg\n", v.name.c_str(), v.rmsPx, v.tiltDeg);
  for (const auto& v : r->rejectedViews) std::printf("  rejected as outlier, re-solved without: %s\n", v.c_str());
  for (const auto& v : views)
    if (!v.found) std::printf("  pattern not found, not used: %s\n", v.name.c_str());
  std::printf("coverage: %.0f %% of the image, tilt %.1f..%.1f deg\n", r->coverage.imageCoverage * 100,
              r->coverage.minTiltDeg, r->coverage.maxTiltDeg);
  for (const auto& a : r->coverage.advice) std::printf("  more views needed: %s\n", a.c_str());
  std::printf("result: rms %.4f px, fx %.3f fy %.3f cx %.3f cy %.3f, k1 %.5f k2 %.5f p1 %.6f p2 %.6f k3 %.5f, %zu views used\n",
              c.rmsPx, c.fx(), c.fy(), c.cx(), c.cy(), c.dist[0], c.dist[1], c.dist[2], c.dist[3], c.dist[4],
              r->usedViews.size());
  const auto& sd = c.stdDev;
  std::printf("std dev: fx %.3f fy %.3f cx %.3f cy %.3f px, k1 %.5f k2 %.5f p1 %.6f p2 %.6f k3 %.5f\n", sd[0], sd[1], sd[2],
              sd[3], sd[4], sd[5], sd[6], sd[7], sd[8]);
  if (c.tangential)
    std::printf("tangential distortion: p1 %.1f std dev, p2 %.1f std dev from 0%s\n", r->coverage.p1Sigmas,
                r->coverage.p2Sigmas,
                std::max(r->coverage.p1Sigmas, r->coverage.p2Sigmas) < 2
                    ? " (not significant: --no-tangential would pin the principal point down better)"
                    : "");
  else
    std::printf("tangential distortion held at 0 (--no-tangential)\n");
  if (auto w = calib::writeIntrinsics(o.out, c); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    nlohmann::json j{{"rms_px", c.rmsPx}, {"fx", c.fx()}, {"fy", c.fy()}, {"cx", c.cx()}, {"cy", c.cy()},
                     {"dist", {c.dist[0], c.dist[1], c.dist[2], c.dist[3], c.dist[4]}},
                     {"std_dev", {sd[0], sd[1], sd[2], sd[3], sd[4], sd[5], sd[6], sd[7], sd[8]}},
                     {"tangential", c.tangential},
                     {"views_used", r->usedViews.size()}, {"views_total", views.size()},
                     {"rejected", r->rejectedViews}, {"coverage", r->coverage.imageCoverage},
                     {"advice", r->coverage.advice}, {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

int runCalibrateHandEye(const CalibHandEyeOptions& o) {
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  auto cam = calib::readIntrinsics(o.intrinsics);
  if (!cam) return bad(cam.error().message);
  const std::string posePath = (fs::path(o.folder) / "poses.txt").string();
  auto poses = calib::loadPoseFile(posePath);
  if (!poses) return bad(poses.error().message);
  // Images in the folder that poses.txt does not mention: a count mismatch worth an error.
  std::vector<std::string> unlisted;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(o.folder, ec)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".png" && ext != ".bmp" && ext != ".tif" && ext != ".tiff" && ext != ".jpg") continue;
    const std::string n = e.path().filename().string();
    if (std::none_of(poses->begin(), poses->end(), [&](const auto& p) { return p.image == n; })) unlisted.push_back(n);
  }
  if (!unlisted.empty()) {
    std::sort(unlisted.begin(), unlisted.end());
    std::string list;
    for (const auto& u : unlisted) list += (list.empty() ? "" : ", ") + u;
    return bad(fmt::format("{}: {} poses but {} more images in {} without a pose: {}", posePath, poses->size(),
                           unlisted.size(), o.folder, list));
  }
  std::vector<calib::HandEyeView> views;
  std::vector<std::string> notFound;
  for (std::size_t i = 0; i < poses->size(); ++i) {
    const auto& p = (*poses)[i];
    const std::string file = (fs::path(o.folder) / p.image).string();
    const cv::Mat img = cv::imread(file, cv::IMREAD_GRAYSCALE);
    if (img.empty()) return bad(fmt::format("{}:{}: image '{}' cannot be read", posePath, p.line, p.image));
    if (img.size() != cam->imageSize)
      return bad(fmt::format("{}: {}x{} px, the intrinsics are for {}x{} px", file, img.cols, img.rows,
                             cam->imageSize.width, cam->imageSize.height));
    auto d = calib::detectPattern(img, *spec, p.image);
    if (d.found && !d.ids.empty() && d.ids.size() != static_cast<std::size_t>(spec->cols * spec->rows)) {
      d.found = false;  // hand-eye uses the whole plate in every view
      d.note = fmt::format("partial charuco view, {} of {} corners: hand-eye needs the whole plate", d.corners.size(),
                           spec->cols * spec->rows);
    }
    progress(i + 1, poses->size(), p.image, d.found ? "found" : "pattern NOT found" + (d.note.empty() ? "" : ": " + d.note));
    if (!d.found) {
      notFound.push_back(p.image);
      continue;
    }
    views.push_back({p.image, p.baseFromGripper, d.corners});
  }
  if (!notFound.empty()) {
    std::string list;
    for (const auto& u : notFound) list += (list.empty() ? "" : ", ") + u;
    std::fprintf(stderr, "warning: pattern not found in %zu of %zu images, they are left out: %s\n", notFound.size(),
                 poses->size(), list.c_str());
  }
  Result<calib::HandEyeResult> r = o.configuration == "auto" ? calib::calibrateHandEyeAuto(views, *cam, *spec)
                                   : o.configuration == "eye-in-hand"
                                       ? calib::calibrateHandEye(views, *cam, *spec, calib::HandEyeConfig::EyeInHand)
                                   : o.configuration == "eye-to-hand"
                                       ? calib::calibrateHandEye(views, *cam, *spec, calib::HandEyeConfig::EyeToHand)
                                       : Result<calib::HandEyeResult>(fail(Status::BadArgument,
                                             fmt::format("--configuration '{}': expected eye-in-hand, eye-to-hand or auto",
                                                         o.configuration)));
  if (!r) return bad(r.error().message);
  std::optional<calib::HandEyeFile> truth;
  if (!o.truth.empty()) {
    auto t = calib::readHandEye(o.truth);
    if (!t) return bad(t.error().message);
    truth = *t;
  }
  for (const auto& w : r->warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("hand-eye %s, %zu views\n", calib::handEyeConfigName(r->config), views.size());
  std::printf("  %-13s %-5s %11s %11s %10s%s\n", "method", "ok", "resid_mm", "resid_deg", "reproj_px",
              truth ? "   err_X_mm  err_X_deg" : "");
  nlohmann::json methods = nlohmann::json::array();
  for (const auto& m : r->methods) {
    std::string tr;
    double emm = -1, edeg = -1;
    if (truth && m.x.qw * m.x.qw + m.x.qx * m.x.qx + m.x.qy * m.x.qy + m.x.qz * m.x.qz > 0.5) {
      const se3::Iso d = se3::toIso(truth->x).inverse() * se3::toIso(m.x);
      emm = d.translation().norm();
      edeg = se3::rotationAngleDeg(d.linear());
      tr = fmt::format(" {:10.3f} {:10.4f}", emm, edeg);
    }
    std::printf("  %-13s %-5s %11.3f %11.4f %10.3f%s%s\n", m.method.c_str(), m.valid ? "yes" : "NO", m.transResidMm,
                m.rotResidDeg, m.reprojRmsPx, tr.c_str(), m.valid ? "" : ("  " + m.note).c_str());
    methods.push_back({{"method", m.method}, {"valid", m.valid}, {"resid_mm", m.transResidMm},
                       {"resid_deg", m.rotResidDeg}, {"reproj_px", m.reprojRmsPx}, {"note", m.note}});
    if (truth) methods.back()["err_x_mm"] = emm, methods.back()["err_x_deg"] = edeg;
  }
  std::printf("chosen: %s\n", r->reason.c_str());
  if (auto w = calib::writeHandEye(o.out, *r); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    const auto& b = r->bestResult();
    const Vec3 rv = toRotationVector(b.x);
    nlohmann::json j{{"configuration", calib::handEyeConfigName(r->config)},
                     {"method", b.method},
                     {"x_mm", {b.x.x, b.x.y, b.x.z}},
                     {"x_rotvec_rad", {rv.x, rv.y, rv.z}},
                     {"resid_mm", b.transResidMm},
                     {"resid_deg", b.rotResidDeg},
                     {"reproj_px", b.reprojRmsPx},
                     {"views_used", views.size()},
                     {"methods", methods},
                     {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

int runCalibratePlane(const CalibPlaneOptions& o) {
  calib::WorkPlane plane;
  std::string source;
  if (!o.points.empty() == !o.image.empty()) return bad("give either --image (a plate on the conveyor) or --points FILE");
  if (!o.points.empty()) {
    std::ifstream f(o.points);
    if (!f) return bad(fmt::format("{}: cannot open", o.points));
    std::vector<Vec3> pts;
    std::string line;
    for (int n = 1; std::getline(f, line); ++n) {
      if (auto h = line.find('#'); h != std::string::npos) line.resize(h);
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      std::istringstream ls(line);
      Vec3 p;
      std::string extra;
      if (!(ls >> p.x >> p.y >> p.z) || (ls >> extra))
        return bad(fmt::format("{}:{}: expected 'x y z' in mm", o.points, n));
      pts.push_back(p);
    }
    auto fit = calib::planeFromPoints(pts);
    if (!fit) return bad(fmt::format("{}: {}", o.points, fit.error().message));
    plane = *fit;
    source = "points";
    std::printf("plane through %zu touched points: fit rms %.3f mm\n", pts.size(), plane.fitRmsMm);
  } else {
    auto spec = patternSpec(o.pattern);
    if (!spec) return bad(spec.error().message);
    auto cam = calib::readIntrinsics(o.intrinsics);
    if (!cam) return bad(cam.error().message);
    auto he = calib::readHandEye(o.handeye);
    if (!he) return bad(he.error().message);
    if (he->config != calib::HandEyeConfig::EyeToHand)
      return bad(fmt::format("{}: an eye-in-hand calibration needs the snapshot pose; use --points", o.handeye));
    const cv::Mat img = cv::imread(o.image, cv::IMREAD_GRAYSCALE);
    if (img.empty()) return bad(fmt::format("{}: cannot read the image", o.image));
    const auto d = calib::detectPattern(img, *spec, o.image);
    if (!d.found)
      return bad(fmt::format("{}: the {} {}x{} was not found{}", o.image, o.pattern.pattern, o.pattern.cols,
                             o.pattern.rows, d.note.empty() ? "" : " (" + d.note + ")"));
    cv::Vec3d rv, tv;
    cv::solvePnP(viewObjectPoints(*spec, d), d.corners, cam->cameraMatrix, cam->dist, rv, tv);
    plane = calib::planeFromPlate(he->x, se3::toPose(se3::fromRvecTvec(rv, tv)), o.thicknessMm);
    source = "plate";
    std::printf("plane from the plate in %s (thickness %.2f mm)\n", o.image.c_str(), o.thicknessMm);
  }
  std::printf("point %.3f %.3f %.3f mm, normal %.6f %.6f %.6f\n", plane.point.x, plane.point.y, plane.point.z,
              plane.normal.x, plane.normal.y, plane.normal.z);
  if (auto w = calib::writeWorkPlane(o.out, plane, source); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    nlohmann::json j{{"point_mm", {plane.point.x, plane.point.y, plane.point.z}},
                     {"normal", {plane.normal.x, plane.normal.y, plane.normal.z}},
                     {"fit_rms_mm", plane.fitRmsMm}, {"source", source}, {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

namespace {

// The views' images, poses.txt and truth.yaml (handeye.yaml layout, for `--truth`) in `dir`.
int writeHandEyeSet(const sim::TrueCamera& cam, const calib::PatternSpec& spec, const sim::HandEyeScenario& s,
                    const CalibSynthOptions& o, const fs::path& dir) {
  sim::PlateRenderOptions ro;
  std::vector<calib::PoseEntry> poses;
  for (std::size_t i = 0; i < s.camFromPlate.size(); ++i) {
    ro.seed = o.seed * 1000 + i;
    const std::string name = fmt::format("pose_{:03d}.png", i);
    cv::imwrite((dir / name).string(), sim::renderPlate(cam, spec, s.camFromPlate[i], ro));
    poses.push_back({name, s.robotReported[i], 0});
    progress(i + 1, s.camFromPlate.size(), name, "rendered");
  }
  if (auto w = calib::writePoseFile((dir / "poses.txt").string(), o.poseFormat, poses); !w) return bad(w.error().message);
  if (auto w = calib::writeHandEyeTruth((dir / "truth.yaml").string(), s.config, s.x, s.y); !w) return bad(w.error().message);
  return 0;
}

// A plate lying face up on the conveyor plane (z = planeZ), centred at (x, y), for
// `vgr calibrate plane --image`, seen by the eye-to-hand camera mounted at `baseFromCam`.
void writeConveyorPlate(const sim::TrueCamera& cam, const calib::PatternSpec& spec, const Pose& baseFromCam, double x,
                        double y, double planeZ, std::uint64_t seed, const fs::path& dir) {
  const Eigen::Vector3d centre((spec.cols - 1) * spec.pitchMm / 2, (spec.rows - 1) * spec.pitchMm / 2, 0);
  const se3::Iso basePlate = Eigen::Translation3d(x, y, planeZ) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::Translation3d(-centre);
  sim::PlateRenderOptions ro;
  ro.seed = seed * 1000 + 999;
  fs::create_directories(dir);  // not in the hand-eye folder: it has no robot pose
  cv::imwrite((dir / "conveyor_plate.png").string(),
              sim::renderPlate(cam, spec, se3::toPose(se3::toIso(baseFromCam).inverse() * basePlate), ro));
}

Result<void> writeCameraTruth(const sim::TrueCamera& cam, const fs::path& path) {
  calib::CameraIntrinsics truthCam;
  truthCam.cameraMatrix = cam.cameraMatrix;
  truthCam.dist = cam.dist;
  truthCam.imageSize = cam.imageSize;
  return calib::writeIntrinsics(path.string(), truthCam);
}

// --kind cell: what commissioning a real eye-to-hand cell collects, for the cell's own
// camera (docs/calibration.md, "The simulated cell, calibrated like a real one"):
// intrinsics/ (a plate shown at varied tilts), handeye/ (the plate on the flange, robot
// poses), plane/ (the plate lying on the conveyor).
int synthCell(const CalibSynthOptions& o, const calib::PatternSpec& spec) {
  auto cell = o.cellConfig.empty() ? config::parseCellConfig(config::embeddedSimCellYaml(), "<embedded sim-cell.yaml>")
                                   : config::loadCellConfig(o.cellConfig);
  if (!cell) return bad(cell.error().message);
  const sim::TrueCamera cam = sim::cellCamera(*cell);
  const Pose mount = sim::cellCameraMount(*cell);
  // Plates held 300-460 mm below a camera 500 mm above the belt (randomPlateViews: +-20 %).
  const double distance = std::min(o.distanceMm, 0.76 * (cell->model.camZ - cell->model.planeZ));
  const fs::path out(o.out);
  fs::create_directories(out / "intrinsics");
  fs::create_directories(out / "handeye");
  if (auto w = writeCameraTruth(cam, out / "camera_truth.yaml"); !w) return bad(w.error().message);
  sim::PlateRenderOptions ro;
  if (o.partialShare > 0 && spec.kind != calib::PatternKind::Charuco)
    return bad(fmt::format("--partial {}: partial views need --pattern charuco (a {} must be seen whole)", o.partialShare,
                           o.pattern.pattern));
  // --partial applies to the intrinsics views only: hand-eye and plane need the whole plate.
  const auto views = sim::randomPlateViews(cam, spec, o.views, o.seed, distance, o.maxTiltDeg, 25, o.partialShare);
  for (std::size_t i = 0; i < views.size(); ++i) {
    ro.seed = o.seed * 1000 + 500 + i;
    const std::string name = fmt::format("plate_{:03d}.png", i);
    cv::imwrite((out / "intrinsics" / name).string(), sim::renderPlate(cam, spec, views[i], ro));
    progress(i + 1, views.size(), "intrinsics/" + name, "rendered");
  }
  const auto s = sim::makeHandEyeScenario(calib::HandEyeConfig::EyeToHand, cam, spec, o.views, o.seed + 1, o.robotNoiseMm,
                                          o.robotNoiseDeg, mount, distance);
  if (int rc = writeHandEyeSet(cam, spec, s, o, out / "handeye"); rc != 0) return rc;
  writeConveyorPlate(cam, spec, mount, cell->model.camX, cell->model.camY, cell->model.planeZ, o.seed, out / "plane");
  std::printf("%s: intrinsics/ (%zu views), handeye/ (%zu poses, eye-to-hand, %s), plane/ and camera_truth.yaml for %s\n",
              o.out.c_str(), views.size(), s.camFromPlate.size(), o.poseFormat.c_str(),
              o.cellConfig.empty() ? "the embedded sim cell" : o.cellConfig.c_str());
  return 0;
}

}  // namespace

int runCalibrateSynth(const CalibSynthOptions& o) {
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  if (o.out.empty()) return bad("--out: a folder is needed");
  if (o.poseFormat != "abb" && o.poseFormat != "fanuc" && o.poseFormat != "ur")
    return bad(fmt::format("--pose-format '{}': expected abb, fanuc or ur", o.poseFormat));
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return bad(fmt::format("{}: {}", o.out, ec.message()));
  if (o.kind == "cell") return synthCell(o, *spec);
  const sim::TrueCamera cam = sim::defaultCalibCamera();
  // The true camera, in the intrinsics file format (for comparison).
  if (auto w = writeCameraTruth(cam, fs::path(o.out) / "camera_truth.yaml"); !w) return bad(w.error().message);
  if (o.kind == "intrinsics") {
    sim::PlateRenderOptions ro;
    if (o.partialShare > 0 && spec->kind != calib::PatternKind::Charuco)
      return bad(fmt::format("--partial {}: partial views need --pattern charuco (a {} must be seen whole)",
                             o.partialShare, o.pattern.pattern));
    const auto poses = sim::randomPlateViews(cam, *spec, o.views, o.seed, o.distanceMm, o.maxTiltDeg, 25, o.partialShare);
    for (std::size_t i = 0; i < poses.size(); ++i) {
      ro.seed = o.seed * 1000 + i;
      const std::string name = fmt::format("plate_{:03d}.png", i);
      cv::imwrite((fs::path(o.out) / name).string(), sim::renderPlate(cam, *spec, poses[i], ro));
      progress(i + 1, poses.size(), name, "rendered");
    }
    std::printf("%zu plate images and camera_truth.yaml in %s\n", poses.size(), o.out.c_str());
    return 0;
  }
  if (o.kind != "handeye") return bad(fmt::format("--kind '{}': expected intrinsics, handeye or cell", o.kind));
  calib::HandEyeConfig cfg;
  if (o.configuration == "eye-in-hand") cfg = calib::HandEyeConfig::EyeInHand;
  else if (o.configuration == "eye-to-hand") cfg = calib::HandEyeConfig::EyeToHand;
  else return bad(fmt::format("--configuration '{}': expected eye-in-hand or eye-to-hand", o.configuration));
  const auto s = sim::makeHandEyeScenario(cfg, cam, *spec, o.views, o.seed, o.robotNoiseMm, o.robotNoiseDeg);
  if (int rc = writeHandEyeSet(cam, *spec, s, o, fs::path(o.out)); rc != 0) return rc;
  if (cfg == calib::HandEyeConfig::EyeToHand) writeConveyorPlate(cam, *spec, s.x, 330, -60, 0, o.seed, fs::path(o.out) / "plane");
  std::printf("%zu images, poses.txt (%s), truth.yaml and camera_truth.yaml in %s\n", s.camFromPlate.size(),
              o.poseFormat.c_str(), o.out.c_str());
  return 0;
}

}  // namespace vgr::daemon
