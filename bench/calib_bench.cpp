// vgr-bench-calib: the accuracy tables of docs/calibration.md, on synthetic data with ground
// truth (sim/calib_scene). Corner-level data (projected points + Gaussian noise), so the
// numbers measure the solvers, not the detector. Deterministic (seeded).
//   build/bin/vgr-bench-calib [--seeds N] [--only intrinsics|handeye|handeye-cloud|mapping]
// handeye-cloud runs the whole depth-camera pipeline instead: rendered depth images with
// pixel noise, sphere detection, labelling, then every method (sim/depth_calib_scene).
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <fmt/core.h>
#include <opencv2/calib3d.hpp>

#include "sim/calib_scene.hpp"
#include "sim/depth_calib_scene.hpp"
#include "vision/calib/handeye_cloud.hpp"
#include "vision/calib/sphere_target.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/multi_height.hpp"
#include "vision/calib/se3.hpp"

namespace {

using namespace vgr;
namespace calib = vision::calib;
namespace se3 = vision::se3;

std::vector<calib::ViewDetection> cornerViews(const sim::TrueCamera& cam, const calib::PatternSpec& spec, int n,
                                              double sigma, std::uint64_t seed, double dist, double tilt,
                                              double partialShare = 0) {
  std::vector<calib::ViewDetection> views;
  const auto poses = sim::randomPlateViews(cam, spec, n, seed, dist, tilt, 25, partialShare);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::string name = "view" + std::to_string(i);
    if (partialShare > 0) {  // charuco: the corners inside the image, with their ids
      auto v = sim::visiblePattern(cam, spec, poses[i], 10, name);
      v.corners = sim::addCornerNoise(v.corners, sigma, seed * 100 + i);
      views.push_back(v);
    } else {
      views.push_back({name, true, sim::addCornerNoise(sim::projectPattern(cam, spec, poses[i]), sigma, seed * 100 + i), {}, {}});
    }
  }
  return views;
}

// docs/calibration.md's bar (0.1 % focal, 0.5 px principal point) on corner-level data, per data design.
// "pred. sd" is calibrateIntrinsics' own standard deviation (mean over seeds), "rms err" the
// RMS of the actual error over the seeds: the two agree when the std dev is trustworthy.
void intrinsicsTable(int seeds) {
  const auto cam = sim::defaultCalibCamera();
  struct Case {
    const char* name;
    calib::PatternSpec spec;
    int views;
    double dist, tilt, partial;
    bool tangential;
  };
  const calib::PatternSpec board96{calib::PatternKind::Chessboard, 9, 6, 20};
  const calib::PatternSpec board118{calib::PatternKind::Chessboard, 11, 8, 20};
  const calib::PatternSpec board2115{calib::PatternKind::Chessboard, 21, 15, 10};
  calib::PatternSpec charuco1511{calib::PatternKind::Charuco, 15, 11, 15};
  charuco1511.markerMm = 11;
  const Case cases[] = {
      {"chessboard 9x6 @20 mm, 15 views, 450 mm, tilt <= 35 deg", board96, 15, 450, 35, 0, true},
      {"chessboard 11x8 @20 mm, 30 views, 400 mm, tilt <= 45 deg", board118, 30, 400, 45, 0, true},
      {"chessboard 11x8 @20 mm, 30 views, 400 mm, tilt <= 45 deg, --no-tangential", board118, 30, 400, 45, 0, false},
      {"chessboard 21x15 @10 mm, 60 views, 400 mm, tilt <= 40 deg", board2115, 60, 400, 40, 0, true},
      {"charuco 15x11 @15 mm, 40 frame-filling views, 250 mm, tilt <= 40 deg", charuco1511, 40, 250, 40, 1.0, true},
  };
  std::printf("\n## Intrinsics, 0.1 px corner noise, %d seeds\n\n", seeds);
  std::printf("| data | max abs fx err | max abs fy err | max abs cx err | max abs cy err | rms err cx / cy | pred. sd cx / cy | seeds within bound | worst seed | advice \"principal point poorly determined\" |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& c : cases) {
    double mfx = 0, mfy = 0, mcx = 0, mcy = 0, sxx = 0, syy = 0, psx = 0, psy = 0, worst = -1;
    int ok = 0, n = 0, worstSeed = 0, flagged = 0;
    for (int s = 1; s <= seeds; ++s) {
      calib::IntrinsicsOptions o;
      o.tangential = c.tangential;
      auto r = calib::calibrateIntrinsics(
          cornerViews(cam, c.spec, c.views, 0.1, static_cast<std::uint64_t>(s), c.dist, c.tilt, c.partial), c.spec,
          cam.imageSize, o);
      if (!r) {
        std::printf("seed %d: %s\n", s, r.error().message.c_str());
        continue;
      }
      ++n;
      const double efx = std::abs(r->camera.fx() / cam.cameraMatrix(0, 0) - 1) * 100;
      const double efy = std::abs(r->camera.fy() / cam.cameraMatrix(1, 1) - 1) * 100;
      const double ecx = std::abs(r->camera.cx() - cam.cameraMatrix(0, 2));
      const double ecy = std::abs(r->camera.cy() - cam.cameraMatrix(1, 2));
      mfx = std::max(mfx, efx), mfy = std::max(mfy, efy), mcx = std::max(mcx, ecx), mcy = std::max(mcy, ecy);
      sxx += ecx * ecx, syy += ecy * ecy, psx += r->camera.stdDev[2], psy += r->camera.stdDev[3];
      ok += efx < 0.1 && efy < 0.1 && ecx < 0.5 && ecy < 0.5;
      for (const auto& a : r->coverage.advice) flagged += a.find("principal point poorly determined") != std::string::npos;
      if (std::max(ecx, ecy) > worst) worst = std::max(ecx, ecy), worstSeed = s;
    }
    const double dn = std::max(n, 1);
    std::printf("| %s | %.3f %% | %.3f %% | %.2f px | %.2f px | %.2f / %.2f px | %.2f / %.2f px | %d / %d | %d (%.2f px) | %d / %d |\n",
                c.name, mfx, mfy, mcx, mcy, std::sqrt(sxx / dn), std::sqrt(syy / dn), psx / dn, psy / dn, ok, seeds,
                worstSeed, worst, flagged, seeds);
    std::fflush(stdout);
  }
}

void handEyeTable(int seeds) {
  const auto cam = sim::defaultCalibCamera();
  const calib::PatternSpec spec{calib::PatternKind::Chessboard, 9, 6, 20};
  calib::CameraIntrinsics ci;
  ci.cameraMatrix = cam.cameraMatrix;
  ci.dist = cam.dist;
  ci.imageSize = cam.imageSize;
  for (auto cfg : {calib::HandEyeConfig::EyeInHand, calib::HandEyeConfig::EyeToHand}) {
    struct Acc {
      int valid = 0, n = 0;
      double sumMm = 0, maxMm = 0, sumDeg = 0, maxDeg = 0;
    };
    std::map<std::string, Acc> acc;
    std::vector<std::string> order;
    for (int s = 1; s <= seeds; ++s) {
      const auto sc = sim::makeHandEyeScenario(cfg, cam, spec, 15, static_cast<std::uint64_t>(s), 0.05, 0.01);
      std::vector<calib::HandEyeView> views;
      for (std::size_t i = 0; i < sc.camFromPlate.size(); ++i)
        views.push_back({"pose" + std::to_string(i), sc.robotReported[i],
                         sim::addCornerNoise(sim::projectPattern(cam, spec, sc.camFromPlate[i]), 0.2, s * 1000 + i)});
      auto r = calib::calibrateHandEye(views, ci, spec, cfg);
      if (!r) {
        std::printf("seed %d: %s\n", s, r.error().message.c_str());
        continue;
      }
      auto add = [&](const std::string& name, const calib::HandEyeMethodResult& m) {
        if (!acc.count(name)) order.push_back(name);
        Acc& a = acc[name];
        ++a.n;
        if (!m.valid) return;
        ++a.valid;
        const se3::Iso d = se3::toIso(sc.x).inverse() * se3::toIso(m.x);
        const double mm = d.translation().norm(), deg = se3::rotationAngleDeg(d.linear());
        a.sumMm += mm, a.sumDeg += deg, a.maxMm = std::max(a.maxMm, mm), a.maxDeg = std::max(a.maxDeg, deg);
      };
      for (const auto& m : r->methods) add(m.method, m);
      add("(chosen)", r->bestResult());
    }
    std::printf("\n## Hand-eye %s: 15 poses, 0.2 px corners, 0.05 mm / 0.01 deg robot noise, %d seeds; error of X\n\n",
                calib::handEyeConfigName(cfg), seeds);
    std::printf("| method | valid | mean mm | max mm | mean deg | max deg |\n|---|---|---|---|---|---|\n");
    for (const auto& name : order) {
      const Acc& a = acc[name];
      const double v = std::max(a.valid, 1);
      std::printf("| %s | %d / %d | %.3f | %.3f | %.4f | %.4f |\n", name.c_str(), a.valid, a.n, a.sumMm / v, a.maxMm,
                  a.sumDeg / v, a.maxDeg);
    }
  }
}

// Paper 003's point-cloud hand-eye and every other method on the same depth-camera data:
// 15 poses of the sphere target, 0.3 mm depth noise per pixel (16-bit, 0.05 mm units),
// robot noise 0.05 mm / 0.01 deg; error of X against the truth.
void handEyeCloudTable(int seeds) {
  const auto cam = sim::defaultDepthCamera();
  const auto target = sim::defaultSphereTarget();
  const auto footprint = sim::sphereTargetFootprint();
  sim::TrueCamera plateCam;
  plateCam.cameraMatrix = cv::Matx33d(cam.intrinsics.fx, 0, cam.intrinsics.cx, 0, cam.intrinsics.fy, cam.intrinsics.cy, 0, 0, 1);
  plateCam.dist = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  plateCam.imageSize = cv::Size(cam.width, cam.height);
  for (auto cfg : {calib::HandEyeConfig::EyeInHand, calib::HandEyeConfig::EyeToHand}) {
    struct Acc {
      int valid = 0, n = 0;
      double sumMm = 0, maxMm = 0, sumDeg = 0, maxDeg = 0;
    };
    std::map<std::string, Acc> acc;
    std::vector<std::string> order;
    double centreSum = 0, centreMax = 0;
    int centres = 0, viewsLost = 0;
    for (int s = 1; s <= seeds; ++s) {
      const auto sc = sim::makeHandEyeScenario(cfg, plateCam, footprint, 15, static_cast<std::uint64_t>(s), 0.05, 0.01,
                                               std::nullopt, 450);
      std::vector<calib::CloudHandEyeView> views;
      for (std::size_t i = 0; i < sc.camFromPlate.size(); ++i) {
        sim::DepthRenderOptions ro;
        ro.noiseSigmaMm = 0.3;
        ro.seed = static_cast<std::uint64_t>(s) * 1000 + i;
        cv::Mat depth;
        sim::quantiseDepth(sim::renderSphereTargetDepth(cam, target, footprint, sc.camFromPlate[i], ro), cam.depthScaleMm)
            .convertTo(depth, CV_32F, cam.depthScaleMm);
        auto m = calib::matchSphereTarget(calib::findSpheres(depth, cam.intrinsics, target.radiusMm), target);
        if (!m) {
          ++viewsLost;
          continue;
        }
        const se3::Iso t = se3::toIso(sc.camFromPlate[i]);
        for (std::size_t j = 0; j < m->ids.size(); ++j) {
          const auto& c = target.centres[static_cast<std::size_t>(m->ids[j])];
          const double e = (t * Eigen::Vector3d(c.x, c.y, c.z) - Eigen::Vector3d(m->points[j].x, m->points[j].y, m->points[j].z)).norm();
          centreSum += e, centreMax = std::max(centreMax, e), ++centres;
        }
        views.push_back({"pose" + std::to_string(i), sc.robotReported[i], m->ids, m->points});
      }
      auto r = calib::calibrateHandEyeCloud(views, target, cfg);
      if (!r) {
        std::printf("seed %d: %s\n", s, r.error().message.c_str());
        continue;
      }
      auto add = [&](const std::string& name, const calib::HandEyeMethodResult& m) {
        if (!acc.count(name)) order.push_back(name);
        Acc& a = acc[name];
        ++a.n;
        if (!m.valid) return;
        ++a.valid;
        const se3::Iso d = se3::toIso(sc.x).inverse() * se3::toIso(m.x);
        const double mm = d.translation().norm(), deg = se3::rotationAngleDeg(d.linear());
        a.sumMm += mm, a.sumDeg += deg, a.maxMm = std::max(a.maxMm, mm), a.maxDeg = std::max(a.maxDeg, deg);
      };
      for (const auto& m : r->methods) add(m.method, m);
      add("(chosen)", r->bestResult());
    }
    std::printf("\n## Depth-camera hand-eye %s: 15 poses of the sphere target, 0.3 mm depth noise, 0.05 mm / 0.01 deg "
                "robot noise, %d seeds; error of X\n\n",
                calib::handEyeConfigName(cfg), seeds);
    std::printf("Sphere centres: mean %.3f mm, max %.3f mm from the truth (%d centres); views without the target: %d\n\n",
                centres ? centreSum / centres : 0.0, centreMax, centres, viewsLost);
    std::printf("| method | valid | mean mm | max mm | mean deg | max deg |\n|---|---|---|---|---|---|\n");
    for (const auto& name : order) {
      const Acc& a = acc[name];
      const double v = std::max(a.valid, 1);
      std::printf("| %s | %d / %d | %.3f | %.3f | %.4f | %.4f |\n", name.c_str(), a.valid, a.n, a.sumMm / v, a.maxMm,
                  a.sumDeg / v, a.maxDeg);
    }
  }
}

// Paper 001's multi-height grid vs the camera model's ray/plane mapping.
void mappingTable(int seeds) {
  const auto cam = sim::defaultCalibCamera();
  // Camera 500 mm above the conveyor (z = 0), looking down, rotated 90 deg like the sim cell.
  const se3::Iso baseCam = Eigen::Translation3d(400, 0, 500) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()) *
                           Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());
  auto project = [&](const Eigen::Vector3d& pb) {
    const Eigen::Vector3d pc = baseCam.inverse() * pb;
    std::vector<cv::Point2d> img;
    cv::projectPoints(std::vector<cv::Point3d>{{pc.x(), pc.y(), pc.z()}}, cv::Vec3d(), cv::Vec3d(), cam.cameraMatrix,
                      cam.dist, img);
    return vision::PixelPoint{img[0].x, img[0].y};
  };
  const calib::PatternSpec plate{calib::PatternKind::Chessboard, 11, 8, 20};
  struct Stat {
    double sum = 0, max = 0;
    int n = 0, miss = 0;
    void add(double e) { sum += e, max = std::max(max, e), ++n; }
  };
  // key: method / region / height
  std::map<std::string, Stat> st;
  std::vector<std::string> keys;
  auto rec = [&](const std::string& k, std::optional<double> e) {
    if (!st.count(k)) keys.push_back(k);
    if (e) st[k].add(*e);
    else ++st[k].miss;
  };
  for (int s = 1; s <= seeds; ++s) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(s) * 77);
    std::normal_distribution<double> px(0, 0.1), mm(0, 0.05);
    // The touched grid: 13 x 15 points, 20 mm apart, centred under the camera, on the
    // conveyor (h = 0) and 9 planes above every 5 mm (paper 001); the tool tip seen with 0.1 px
    // noise, the robot with 0.05 mm noise.
    const int rows = 13, cols = 15;
    std::vector<Vec3> grid;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) grid.push_back({400 - 120 + 20.0 * r, -140 + 20.0 * c, 0});
    std::vector<double> heights;
    std::vector<std::vector<vision::PixelPoint>> image;
    std::vector<Vec3> touched0;
    for (int k = 0; k < 10; ++k) {
      heights.push_back(5.0 * k);
      std::vector<vision::PixelPoint> plane;
      for (const auto& g : grid) {
        auto p = project({g.x + mm(rng), g.y + mm(rng), heights.back() + mm(rng)});
        plane.push_back({p.u + px(rng), p.v + px(rng)});
      }
      image.push_back(plane);
    }
    std::vector<Vec3> gridMeasured;
    for (const auto& g : grid) gridMeasured.push_back({g.x + mm(rng), g.y + mm(rng), mm(rng)});
    auto mh = calib::MultiHeightMap::build(rows, cols, gridMeasured, {0, 0, 1}, heights, image);
    // Ray/plane: intrinsics from 30 plate views (0.1 px), camera pose by solvePnP on the h = 0
    // grid, plane fitted through the touched h = 0 points.
    auto intr = calib::calibrateIntrinsics(cornerViews(cam, plate, 30, 0.1, static_cast<std::uint64_t>(s), 400, 45), plate,
                                           cam.imageSize);
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    for (std::size_t i = 0; i < grid.size(); ++i) {
      obj.push_back({gridMeasured[i].x, gridMeasured[i].y, gridMeasured[i].z});
      img.push_back({image[0][i].u, image[0][i].v});
    }
    cv::Vec3d rv, tv;
    cv::solvePnP(obj, img, intr->camera.cameraMatrix, intr->camera.dist, rv, tv);
    const se3::Iso camBase = se3::fromRvecTvec(rv, tv);
    auto plane = calib::planeFromPoints(gridMeasured);
    const calib::CameraPlaneMapping ray(intr->camera, se3::toPose(camBase.inverse()), *plane);
    std::uniform_real_distribution<double> inX(400 - 115, 400 + 115), inY(-135, 135);
    for (double h : {0.0, 8.0, 25.0, 47.0, 60.0}) {
      for (int i = 0; i < 300; ++i) {
        const Eigen::Vector3d truth(inX(rng), inY(rng), h);
        const auto p = project(truth);
        const auto a = ray.pixelToRobot(p, h);
        const auto b = mh->pixelToRobot(p, h);
        auto err = [&](const std::optional<Vec3>& q) -> std::optional<double> {
          if (!q) return std::nullopt;
          return std::hypot(q->x - truth.x(), q->y - truth.y());
        };
        rec(fmt::format("inside the grid|h = {:g} mm|ray/plane", h), err(a));
        rec(fmt::format("inside the grid|h = {:g} mm|multi-height", h), err(b));
      }
    }
    // Outside the grid (image corners): only the camera model answers.
    for (int i = 0; i < 100; ++i) {
      const Eigen::Vector3d truth(400 + (i % 2 ? 1 : -1) * 200.0, (i % 4 < 2 ? 1 : -1) * 250.0 + (i % 7), 8.0);
      const auto p = project(truth);
      auto a = ray.pixelToRobot(p, 8.0);
      auto b = mh->pixelToRobot(p, 8.0);
      rec("image corners (outside the grid)|h = 8 mm|ray/plane",
          a ? std::optional<double>(std::hypot(a->x - truth.x(), a->y - truth.y())) : std::nullopt);
      rec("image corners (outside the grid)|h = 8 mm|multi-height",
          b ? std::optional<double>(std::hypot(b->x - truth.x(), b->y - truth.y())) : std::nullopt);
    }
  }
  std::printf("\n## Multi-height grid (paper 001) vs ray/plane, distorted camera 500 mm above the belt, %d seeds\n\n", seeds);
  std::printf("| region | height | method | mean mm | max mm | no answer |\n|---|---|---|---|---|---|\n");
  for (const auto& k : keys) {
    const Stat& s = st[k];
    const auto a = k.find('|'), b = k.rfind('|');
    std::printf("| %s | %s | %s | %s | %s | %d |\n", k.substr(0, a).c_str(), k.substr(a + 1, b - a - 1).c_str(),
                k.substr(b + 1).c_str(), s.n ? fmt::format("{:.3f}", s.sum / s.n).c_str() : "-",
                s.n ? fmt::format("{:.3f}", s.max).c_str() : "-", s.miss);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-calib: calibration accuracy tables (docs/calibration.md)"};
  vgr::cli::showDefaults(app);
  int seeds = 20;
  std::string only;
  app.add_option("--seeds", seeds, "random data sets per row")->check(CLI::Range(1, 1000));
  app.add_option("--only", only, "one table: intrinsics, handeye, handeye-cloud or mapping (default: all)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (only.empty() || only == "intrinsics") intrinsicsTable(seeds);
  if (only.empty() || only == "handeye") handEyeTable(seeds);
  if (only.empty() || only == "handeye-cloud") handEyeCloudTable(seeds);
  if (only.empty() || only == "mapping") mappingTable(std::max(1, seeds / 4));
  return 0;
}
