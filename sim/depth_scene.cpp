#include "sim/depth_scene.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <fmt/core.h>
#include <opencv2/core.hpp>

namespace vgr::sim {
namespace {

using V3 = Eigen::Vector3d;
using Iso = Eigen::Isometry3d;

constexpr double kDeg = M_PI / 180.0;

Pose toPose(const Iso& t) {
  Eigen::Quaterniond q(t.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return Pose{t.translation().x(), t.translation().y(), t.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

TriMesh cylinderMesh(double r, double h, int n = 48) {
  TriMesh m;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    m.vertices.push_back({r * std::cos(a), r * std::sin(a), 0});
    m.vertices.push_back({r * std::cos(a), r * std::sin(a), h});
  }
  m.vertices.push_back({0, 0, 0});
  m.vertices.push_back({0, 0, h});
  for (int k = 0; k < n; ++k) {
    const int k1 = (k + 1) % n;
    m.triangles.push_back({2 * k, 2 * k1, 2 * k1 + 1});
    m.triangles.push_back({2 * k, 2 * k1 + 1, 2 * k + 1});
    m.triangles.push_back({2 * n, 2 * k1, 2 * k});
    m.triangles.push_back({2 * n + 1, 2 * k + 1, 2 * k1 + 1});
  }
  return m;
}

Eigen::Matrix3d rowMajor(const std::array<double, 9>& r) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = r[static_cast<std::size_t>(i)];
  return m;
}

// An object resting in the bin: its pose in the bin frame (z up, origin on the floor's
// centre), lifted so its lowest vertex touches the floor, and its footprint circle.
struct Placed {
  const TriMesh* mesh = nullptr;
  Iso binFromMesh = Iso::Identity();
  double cx = 0, cy = 0, radius = 0;  // footprint circle, bin frame, mm
};

// Rotation `r` applied, lifted onto z = 0; the footprint about the xy box centre.
Placed rest(const TriMesh& mesh, const Eigen::Matrix3d& r) {
  Placed p;
  p.mesh = &mesh;
  double zmin = 1e18, xmin = 1e18, xmax = -1e18, ymin = 1e18, ymax = -1e18;
  for (const auto& v : mesh.vertices) {
    const V3 q = r * V3(v[0], v[1], v[2]);
    zmin = std::min(zmin, q.z());
    xmin = std::min(xmin, q.x()), xmax = std::max(xmax, q.x());
    ymin = std::min(ymin, q.y()), ymax = std::max(ymax, q.y());
  }
  const double mx = (xmin + xmax) / 2, my = (ymin + ymax) / 2;
  for (const auto& v : mesh.vertices) {
    const V3 q = r * V3(v[0], v[1], v[2]);
    p.radius = std::max(p.radius, std::hypot(q.x() - mx, q.y() - my));
  }
  p.binFromMesh.linear() = r;
  p.binFromMesh.translation() = V3(-mx, -my, -zmin);  // footprint centred on the origin, on the floor
  return p;
}

// Moves `p` to a free spot of the floor area (half-sizes hx, hy); false if none was found.
bool placeFree(Placed& p, const std::vector<Placed>& others, double hx, double hy, std::mt19937_64& rng) {
  constexpr double kGapMm = 4;
  if (p.radius > hx || p.radius > hy) return false;
  std::uniform_real_distribution<double> ux(-hx + p.radius, hx - p.radius), uy(-hy + p.radius, hy - p.radius);
  for (int attempt = 0; attempt < 200; ++attempt) {
    const double x = ux(rng), y = uy(rng);
    const bool free = std::none_of(others.begin(), others.end(), [&](const Placed& o) {
      return std::hypot(o.cx - x, o.cy - y) < o.radius + p.radius + kGapMm;
    });
    if (!free) continue;
    p.cx = x, p.cy = y;
    p.binFromMesh.translation() += V3(x, y, 0);
    return true;
  }
  return false;
}

Result<void> checkCommon(const std::string& part, const DepthCameraModel& c, const DepthSensorOptions& s) {
  if (auto p = depthPart(part); !p) return std::unexpected(p.error());
  if (c.width < 16 || c.height < 16 || c.width > 8192 || c.height > 8192)
    return fail(Status::BadArgument, fmt::format("camera size {}x{} px: expected 16..8192 each", c.width, c.height));
  if (!(c.fx > 0) || !(c.fy > 0)) return fail(Status::BadArgument, "camera focal lengths must be > 0 px");
  if (!(c.depthScaleMm > 0) || c.depthScaleMm > 10) return fail(Status::BadArgument, "depth scale: expected (0, 10] mm per step");
  if (s.noiseMmAt500 < 0 || s.noiseMmAt500 > 10) return fail(Status::BadArgument, "noise: expected [0, 10] mm at 500 mm");
  if (s.dropout < 0 || s.dropout >= 1) return fail(Status::BadArgument, "dropout: expected [0, 1)");
  if (!(s.jumpMm > 0)) return fail(Status::BadArgument, "jump threshold: expected > 0 mm");
  if (!(s.grazingDeg > 0) || s.grazingDeg > 90) return fail(Status::BadArgument, "grazing angle: expected (0, 90] deg");
  return {};
}

// A uniformly random horizontal axis.
V3 horizontalAxis(std::mt19937_64& rng) {
  const double a = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
  return {std::cos(a), std::sin(a), 0};
}

}  // namespace

Result<DepthScene> renderDepthScene(const DepthSceneOptions& o, std::uint64_t index) {
  if (auto c = checkCommon(o.part, o.camera, o.sensor); !c) return std::unexpected(c.error());
  if (o.partsPerScene < 0 || o.partsPerScene > 8) return fail(Status::BadArgument, "parts per scene: expected 0..8");
  if (o.emptyRatio < 0 || o.emptyRatio > 1) return fail(Status::BadArgument, "empty ratio: expected [0, 1]");
  if (o.clutter < 0 || o.clutter > 32) return fail(Status::BadArgument, "clutter: expected 0..32");
  if (o.tiltMaxDeg < 0 || o.tiltMaxDeg > 60) return fail(Status::BadArgument, "tilt: expected [0, 60] deg");
  if (o.floorMm < 200 || o.floorMm > 5000) return fail(Status::BadArgument, "floor distance: expected [200, 5000] mm");
  if (o.cameraTiltMaxDeg < 0 || o.cameraTiltMaxDeg > 30) return fail(Status::BadArgument, "camera tilt: expected [0, 30] deg");
  if (o.occlusion < 0 || o.occlusion > 0.95) return fail(Status::BadArgument, "occlusion: expected [0, 0.95]");
  const DepthPart part = *depthPart(o.part);
  const StableFace* onlyFace = nullptr;
  if (!o.face.empty()) {
    std::string names;
    for (const auto& f : part.stableFaces) {
      if (f.name == o.face) onlyFace = &f;
      names += (names.empty() ? "" : ", ") + f.name;
    }
    if (!onlyFace) return fail(Status::BadArgument, "face '" + o.face + "': the " + o.part + " rests on " + names);
  }

  std::mt19937_64 rng(o.seed * 0xD1B54A32D192ED03ull + index * 0x94D049BB133111EBull + 77);
  std::uniform_real_distribution<double> u01(0, 1);

  // Camera above the bin looking down (bin z up -> camera z forward), tilted a little.
  Iso camFromBin = Iso::Identity();
  camFromBin.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  camFromBin.translation() = V3(0, 0, o.floorMm);
  const Eigen::Vector3d tiltAxis(horizontalAxis(rng));
  const double camTilt = o.cameraTiltMaxDeg * kDeg * u01(rng);
  camFromBin = Iso(Eigen::AngleAxisd(camTilt, tiltAxis)) * camFromBin;
  {
    // options.view: the same scene from the camera moved to T_cam_view.
    Iso camFromView = Iso::Identity();
    camFromView.linear() = Eigen::Quaterniond(o.view.qw, o.view.qx, o.view.qy, o.view.qz).normalized().toRotationMatrix();
    camFromView.translation() = V3(o.view.x, o.view.y, o.view.z);
    camFromBin = camFromView.inverse() * camFromBin;
  }

  // The bin: 380 x 280 mm floor, 8 mm walls 100 mm high, standing on a wider table.
  const double hx = o.bin ? 190 : 300, hy = o.bin ? 140 : 220;
  std::vector<TriMesh> fixed;
  fixed.push_back(boxMesh({-400, -300, -10}, {400, 300, 0}));
  if (o.bin) {
    fixed.push_back(boxMesh({190, -148, 0}, {198, 148, 100}));
    fixed.push_back(boxMesh({-198, -148, 0}, {-190, 148, 100}));
    fixed.push_back(boxMesh({-198, 140, 0}, {198, 148, 100}));
    fixed.push_back(boxMesh({-198, -148, 0}, {198, -140, 100}));
  }

  // Parts: any stable face, random yaw, tilted up to tiltMaxDeg.
  std::vector<Placed> placed;
  std::vector<std::string> faces;
  const bool empty = u01(rng) < o.emptyRatio;
  const int wanted = empty ? 0 : o.partsPerScene;
  for (int k = 0; k < wanted; ++k) {
    const auto& drawn = part.stableFaces[static_cast<std::size_t>(rng() % part.stableFaces.size())];
    const auto& face = onlyFace ? *onlyFace : drawn;  // drawn either way: the scenes' random sequence stays
    const double yaw = 2 * M_PI * u01(rng);
    const double tilt = o.tiltMaxDeg * kDeg * u01(rng);
    const V3 axis = horizontalAxis(rng);
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(tilt, axis).toRotationMatrix() * Eigen::AngleAxisd(yaw, V3::UnitZ()).toRotationMatrix() * rowMajor(face.rotation);
    Placed p = rest(part.mesh, r);
    if (!placeFree(p, placed, hx, hy, rng)) break;
    placed.push_back(p);
    faces.push_back(face.name);
  }
  const std::size_t nParts = placed.size();

  // Clutter: boxes and cylinders (standing or lying), never touching a part or each other.
  std::vector<TriMesh> clutterMeshes;
  clutterMeshes.reserve(static_cast<std::size_t>(o.clutter));
  std::vector<Eigen::Matrix3d> clutterRot;
  for (int k = 0; k < o.clutter; ++k) {
    std::uniform_real_distribution<double> size(12, 45), height(6, 35), radius(6, 20);
    Eigen::Matrix3d r = Eigen::AngleAxisd(2 * M_PI * u01(rng), V3::UnitZ()).toRotationMatrix();
    if (u01(rng) < 0.6) {
      const double a = size(rng), b = size(rng), c = height(rng);
      clutterMeshes.push_back(boxMesh({-a / 2, -b / 2, 0}, {a / 2, b / 2, c}));
    } else {
      clutterMeshes.push_back(cylinderMesh(radius(rng), height(rng) + 6));
      if (u01(rng) < 0.5) r = r * Eigen::AngleAxisd(M_PI / 2, V3::UnitX()).toRotationMatrix();  // lying
    }
    clutterRot.push_back(r);
  }
  for (std::size_t k = 0; k < clutterMeshes.size(); ++k) {
    Placed p = rest(clutterMeshes[k], clutterRot[k]);
    if (placeFree(p, placed, hx, hy, rng)) placed.push_back(p);
  }

  std::vector<MeshInstance> meshes;
  for (const auto& m : fixed) meshes.push_back({&m, toPose(camFromBin), 0});
  for (std::size_t k = 0; k < placed.size(); ++k)
    meshes.push_back({placed[k].mesh, toPose(camFromBin * placed[k].binFromMesh), static_cast<std::uint16_t>(k < nParts ? k + 1 : 0)});

  DepthScene scene;
  scene.camera = o.camera;
  ExactDepth alone;
  for (std::size_t k = 0; k < nParts; ++k) {
    DepthPartTruth t;
    t.pose = toPose(camFromBin * placed[k].binFromMesh);
    t.face = faces[k];
    rasterize({meshes[fixed.size() + k]}, o.camera, alone);
    t.pixels = cv::countNonZero(alone.labels);
    scene.parts.push_back(t);
  }

  // The occluding board: a fronto-parallel plate 40 mm above the first part covering the
  // image columns that hold the wanted share of the part's pixels.
  TriMesh board;
  if (o.occlusion > 0 && nParts > 0) {
    rasterize({meshes[fixed.size()]}, o.camera, alone);
    std::vector<int> cols;
    int vmin = o.camera.height, vmax = -1, umin = o.camera.width;
    double zmin = 1e18;
    for (int y = 0; y < alone.labels.rows; ++y)
      for (int x = 0; x < alone.labels.cols; ++x)
        if (alone.labels.at<std::uint16_t>(y, x)) {
          cols.push_back(x);
          vmin = std::min(vmin, y), vmax = std::max(vmax, y), umin = std::min(umin, x);
          zmin = std::min(zmin, alone.z.at<double>(y, x));
        }
    if (!cols.empty()) {
      std::sort(cols.begin(), cols.end());
      const std::size_t n = static_cast<std::size_t>(std::lround(o.occlusion * static_cast<double>(cols.size())));
      const double uEdge = n == 0 ? umin - 1.0 : cols[std::min(n, cols.size()) - 1] + 0.5;
      const double zb = zmin - 40;
      auto back = [&](double u, double v, double z) {
        return V3((u - o.camera.cx) / o.camera.fx * z, (v - o.camera.cy) / o.camera.fy * z, z);
      };
      const double u0 = umin - 30.0, v0 = vmin - 30.0, v1 = vmax + 30.0;
      // Corners at the front face z = zb; the board is 3 mm thick.
      board = boxMesh({0, 0, 0}, {1, 1, 1});
      for (auto& v : board.vertices) {
        const double u = v[0] > 0 ? uEdge : u0, vv = v[1] > 0 ? v1 : v0, z = v[2] > 0 ? zb : zb - 3;
        const V3 p = back(u, vv, z);
        v = {p.x(), p.y(), p.z()};
      }
      meshes.push_back({&board, Pose{}, 0});
    }
  }

  ExactDepth exact;
  rasterize(meshes, o.camera, exact);
  for (std::size_t k = 0; k < nParts; ++k) {
    cv::Mat mask = exact.labels == static_cast<int>(k + 1);
    scene.parts[k].visiblePixels = cv::countNonZero(mask);
  }
  scene.labels = exact.labels;
  scene.exactZ = exact.z;
  scene.depth = applySensor(exact, o.camera, o.sensor, o.seed * 0x9E3779B97F4A7C15ull + index);
  return scene;
}

Result<std::vector<PartView>> renderPartViews(const PartViewsOptions& o) {
  if (auto c = checkCommon(o.part, o.camera, o.sensor); !c) return std::unexpected(c.error());
  if (o.views < 3 || o.views > 72) return fail(Status::BadArgument, "views: expected 3..72");
  if (o.distanceMm < 150 || o.distanceMm > 2000) return fail(Status::BadArgument, "view distance: expected [150, 2000] mm");
  for (double e : {o.elevationLowDeg, o.elevationHighDeg})
    if (!(e > 0) || !(e < 90)) return fail(Status::BadArgument, "view elevation: expected (0, 90) deg");
  if (o.poseNoiseMm < 0 || o.poseNoiseMm > 100) return fail(Status::BadArgument, "pose noise: expected [0, 100] mm");
  if (o.poseNoiseDeg < 0 || o.poseNoiseDeg > 45) return fail(Status::BadArgument, "pose noise: expected [0, 45] deg");
  if (o.badView < -1 || o.badView >= o.views) return fail(Status::BadArgument, fmt::format("bad view: expected -1..{}", o.views - 1));
  if (o.badViewMm < 0 || o.badViewMm > 1000) return fail(Status::BadArgument, "bad view offset: expected [0, 1000] mm");
  const DepthPart part = *depthPart(o.part);
  std::mt19937_64 rng(o.seed * 0xBF58476D1CE4E5B9ull + 991);
  std::uniform_real_distribution<double> u11(-1, 1);

  // Table frame: z up, origin on the table under the part's centroid; the part on its -z face.
  Iso tableFromModel = Iso::Identity();
  tableFromModel.translation() = V3(-part.centroid[0], -part.centroid[1], 0);
  const V3 target(0, 0, part.centroid[2]);
  const TriMesh table = boxMesh({-200, -200, -10}, {200, 200, 0});
  const double azimuth0 = 2 * M_PI * (u11(rng) + 1) / 2;

  std::vector<PartView> out;
  ExactDepth exact;
  for (int k = 0; k < o.views; ++k) {
    const double a = azimuth0 + 2 * M_PI * k / o.views;
    const double e = (k % 2 ? o.elevationLowDeg : o.elevationHighDeg) * kDeg;
    const V3 pos = target + o.distanceMm * V3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
    const V3 f = (target - pos).normalized();
    const V3 x = f.cross(V3::UnitZ()).normalized();
    const V3 y = f.cross(x);
    Iso tableFromCam = Iso::Identity();
    tableFromCam.linear().col(0) = x;
    tableFromCam.linear().col(1) = y;
    tableFromCam.linear().col(2) = f;
    tableFromCam.translation() = pos;
    const Iso modelFromCam = tableFromModel.inverse() * tableFromCam;
    const Iso camFromTable = tableFromCam.inverse();
    rasterize({{&table, toPose(camFromTable), 0}, {&part.mesh, toPose(camFromTable * tableFromModel), 1}}, o.camera, exact);

    PartView v;
    v.depth = applySensor(exact, o.camera, o.sensor, o.seed * 0x94D049BB133111EBull + static_cast<std::uint64_t>(k) + 5);
    v.cameraInModel = toPose(modelFromCam);
    // What a robot reports: the camera position off by U(-n, n) mm per axis, its orientation
    // turned by U(-n, n) deg about each axis.
    Iso rep = modelFromCam;
    rep.translation() += o.poseNoiseMm * V3(u11(rng), u11(rng), u11(rng));
    const double rx = o.poseNoiseDeg * kDeg * u11(rng), ry = o.poseNoiseDeg * kDeg * u11(rng), rz = o.poseNoiseDeg * kDeg * u11(rng);
    rep.linear() = (Eigen::AngleAxisd(rz, V3::UnitZ()) * Eigen::AngleAxisd(ry, V3::UnitY()) * Eigen::AngleAxisd(rx, V3::UnitX()))
                       .toRotationMatrix() *
                   rep.linear();
    const V3 dir = V3(u11(rng), u11(rng), u11(rng)).normalized();
    if (k == o.badView) rep.translation() += o.badViewMm * dir;
    v.reported = toPose(rep);
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace vgr::sim
