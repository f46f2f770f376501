#include "sim/depth_parts.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <Eigen/Geometry>
#include <fmt/core.h>

namespace vgr::sim {
namespace {

constexpr int kCylinderSegments = 64;  // a 14 mm hub deviates 0.017 mm from its circle

using V3 = Eigen::Vector3d;

V3 vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

Primitive box(V3 lo, V3 hi) {
  Primitive p;
  p.kind = Primitive::Kind::Box;
  p.min = {lo.x(), lo.y(), lo.z()};
  p.max = {hi.x(), hi.y(), hi.z()};
  return p;
}

Primitive cylinder(double cx, double cy, double r, double z0, double z1) {
  Primitive p;
  p.kind = Primitive::Kind::Cylinder;
  p.cx = cx, p.cy = cy, p.radius = r, p.z0 = z0, p.z1 = z1;
  return p;
}

// The closed mesh of one primitive, appended to `m` (counter-clockwise seen from outside).
void appendMesh(const Primitive& p, TriMesh& m) {
  const int base = static_cast<int>(m.vertices.size());
  auto quad = [&](int a, int b, int c, int d) {  // a b c d counter-clockwise from outside
    m.triangles.push_back({base + a, base + b, base + c});
    m.triangles.push_back({base + a, base + c, base + d});
  };
  if (p.kind == Primitive::Kind::Box) {
    for (int i = 0; i < 8; ++i)
      m.vertices.push_back({(i & 1) ? p.max[0] : p.min[0], (i & 2) ? p.max[1] : p.min[1], (i & 4) ? p.max[2] : p.min[2]});
    quad(0, 2, 3, 1);  // z min (normal -z)
    quad(4, 5, 7, 6);  // z max
    quad(0, 1, 5, 4);  // y min
    quad(2, 6, 7, 3);  // y max
    quad(0, 4, 6, 2);  // x min
    quad(1, 3, 7, 5);  // x max
    return;
  }
  const int n = kCylinderSegments;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    m.vertices.push_back({p.cx + p.radius * std::cos(a), p.cy + p.radius * std::sin(a), p.z0});
    m.vertices.push_back({p.cx + p.radius * std::cos(a), p.cy + p.radius * std::sin(a), p.z1});
  }
  m.vertices.push_back({p.cx, p.cy, p.z0});  // 2n
  m.vertices.push_back({p.cx, p.cy, p.z1});  // 2n + 1
  for (int k = 0; k < n; ++k) {
    const int k1 = (k + 1) % n;
    quad(2 * k, 2 * k1, 2 * k1 + 1, 2 * k + 1);
    m.triangles.push_back({base + 2 * n, base + 2 * k1, base + 2 * k});
    m.triangles.push_back({base + 2 * n + 1, base + 2 * k + 1, base + 2 * k1 + 1});
  }
}

// The primitive as a convex polyhedron: outward planes n . x <= d.
struct Plane {
  V3 n;
  double d;
};
std::vector<Plane> planesOf(const Primitive& p) {
  std::vector<Plane> out;
  if (p.kind == Primitive::Kind::Box) {
    for (int a = 0; a < 3; ++a) {
      V3 n = V3::Zero();
      n[a] = 1;
      out.push_back({n, p.max[a]});
      out.push_back({-n, -p.min[a]});
    }
    return out;
  }
  out.push_back({V3::UnitZ(), p.z1});
  out.push_back({-V3::UnitZ(), -p.z0});
  const int n = kCylinderSegments;
  for (int k = 0; k < n; ++k) {  // the flat between vertices k and k + 1
    const double a = 2 * M_PI * (k + 0.5) / n;
    const V3 nn(std::cos(a), std::sin(a), 0);
    out.push_back({nn, nn.dot(V3(p.cx, p.cy, 0)) + p.radius * std::cos(M_PI / n)});
  }
  return out;
}

bool inside(const std::vector<Plane>& planes, const V3& q, double tol) {
  for (const auto& pl : planes)
    if (pl.n.dot(q) > pl.d + tol) return false;
  return true;
}

double volume(const Primitive& p) {
  if (p.kind == Primitive::Kind::Box) return (p.max[0] - p.min[0]) * (p.max[1] - p.min[1]) * (p.max[2] - p.min[2]);
  return M_PI * p.radius * p.radius * (p.z1 - p.z0);
}
V3 centre(const Primitive& p) {
  if (p.kind == Primitive::Kind::Box) return (vec(p.min) + vec(p.max)) / 2;
  return {p.cx, p.cy, (p.z0 + p.z1) / 2};
}

double cross2(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

// Andrew's monotone chain, counter-clockwise.
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> pts) {
  std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) { return std::tie(a.x(), a.y()) < std::tie(b.x(), b.y()); });
  if (pts.size() < 3) return pts;
  std::vector<Eigen::Vector2d> h(2 * pts.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross2(h[k - 2], h[k - 1], pts[i]) <= 1e-9) --k;
    h[k++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross2(h[k - 2], h[k - 1], pts[i]) <= 1e-9) --k;
    h[k++] = pts[i];
  }
  h.resize(k - 1);
  return h;
}

// Stable faces (a physics-free test): for each model axis d pointing down, the support
// polygon is the convex hull of the lowest vertices; the part rests on it when its volume
// centroid projects inside it at least `marginMm` from every edge.
std::vector<StableFace> stableFaces(const TriMesh& mesh, const V3& centroid) {
  constexpr double kMarginMm = 3;
  std::vector<StableFace> out;
  const std::pair<V3, const char*> downs[] = {{-V3::UnitZ(), "-z"}, {V3::UnitZ(), "+z"}, {V3::UnitX(), "+x"},
                                              {-V3::UnitX(), "-x"}, {V3::UnitY(), "+y"}, {-V3::UnitY(), "-y"}};
  for (const auto& [d, name] : downs) {
    double lowest = -1e18;
    for (const auto& v : mesh.vertices) lowest = std::max(lowest, d.dot(vec(v)));
    const Eigen::Matrix3d r = Eigen::Quaterniond::FromTwoVectors(d, -V3::UnitZ()).toRotationMatrix();
    std::vector<Eigen::Vector2d> support;
    for (const auto& v : mesh.vertices)
      if (d.dot(vec(v)) > lowest - 0.05) support.push_back((r * vec(v)).head<2>());
    const auto hull = convexHull(support);
    if (hull.size() < 3) continue;
    const Eigen::Vector2d c = (r * centroid).head<2>();
    bool ok = true;
    for (std::size_t i = 0; i < hull.size() && ok; ++i) {
      const Eigen::Vector2d a = hull[i], b = hull[(i + 1) % hull.size()];
      ok = cross2(a, b, c) / (b - a).norm() >= kMarginMm;  // left of a counter-clockwise edge
    }
    if (!ok) continue;
    StableFace f;
    for (int i = 0; i < 9; ++i) f.rotation[static_cast<std::size_t>(i)] = r(i / 3, i % 3);
    f.name = name;
    out.push_back(f);
  }
  return out;
}

DepthPart makePart(std::string name, std::vector<Primitive> prims) {
  DepthPart part;
  part.name = std::move(name);
  part.primitives = std::move(prims);
  V3 c = V3::Zero();
  double vol = 0;
  for (const auto& p : part.primitives) {
    appendMesh(p, part.mesh);
    c += volume(p) * centre(p);
    vol += volume(p);
  }
  c /= vol;
  part.centroid = {c.x(), c.y(), c.z()};
  for (const auto& v : part.mesh.vertices) part.radiusMm = std::max(part.radiusMm, vec(v).norm());
  part.stableFaces = stableFaces(part.mesh, c);
  return part;
}

// Sub-triangles of `mesh`'s triangle t, edges at most `edgeMm`: k x k barycentric subdivision.
template <class F>
void subdivide(const TriMesh& mesh, const std::array<int, 3>& t, double edgeMm, F&& emit) {
  const V3 a = vec(mesh.vertices[static_cast<std::size_t>(t[0])]);
  const V3 b = vec(mesh.vertices[static_cast<std::size_t>(t[1])]);
  const V3 c = vec(mesh.vertices[static_cast<std::size_t>(t[2])]);
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const int k = std::max(1, static_cast<int>(std::ceil(longest / edgeMm)));
  auto at = [&](int i, int j) { return a + (b - a) * (double(i) / k) + (c - a) * (double(j) / k); };
  for (int i = 0; i < k; ++i)
    for (int j = 0; i + j < k; ++j) {
      emit(at(i, j), at(i + 1, j), at(i, j + 1));
      if (i + j + 2 <= k) emit(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
    }
}

// On the exterior: a step of 0.02 mm outward along the face normal leaves every primitive
// (so faces inside another primitive, and faces pressed against another, are left out), and
// where faces of several primitives coincide (coplanar bottoms) only the first one's counts.
bool onExterior(const std::vector<std::vector<Plane>>& solids, std::size_t own, const V3& p, const V3& n) {
  const V3 q = p + 0.02 * n;
  for (const auto& s : solids)
    if (inside(s, q, 1e-9)) return false;
  for (std::size_t j = 0; j < own; ++j)
    if (inside(solids[j], p, 1e-6)) return false;
  return true;
}

// Which primitive each triangle of part.mesh belongs to (appendMesh adds them in order).
std::vector<std::size_t> ownerOfTriangles(const DepthPart& part) {
  std::vector<std::size_t> owner;
  for (std::size_t i = 0; i < part.primitives.size(); ++i) {
    TriMesh m;
    appendMesh(part.primitives[i], m);
    owner.insert(owner.end(), m.triangles.size(), i);
  }
  return owner;
}

}  // namespace

TriMesh boxMesh(const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  TriMesh m;
  appendMesh(box(vec(lo), vec(hi)), m);
  return m;
}

const std::vector<std::string>& depthPartNames() {
  static const std::vector<std::string> names{"bracket", "housing", "lever"};
  return names;
}

Result<DepthPart> depthPart(const std::string& name) {
  if (name == "bracket")
    return makePart(name, {box({-30, -20, 0}, {30, 20, 8}), box({-30, -20, 8}, {30, -12, 40}), box({10, -12, 8}, {16, 2, 24}),
                           cylinder(-14, 6, 7, 8, 18)});
  if (name == "housing")
    return makePart(name, {box({-25, -18, 0}, {25, 18, 22}), box({-38, -18, 0}, {-25, -4, 6}), cylinder(10, 4, 9, 22, 34),
                           cylinder(-12, -9, 3.5, 22, 29)});
  if (name == "lever")
    return makePart(name, {cylinder(0, 0, 14, 0, 18), cylinder(56, 0, 8, 0, 10), box({0, -5, 0}, {56, 5, 8}),
                           box({24, 5, 0}, {32, 12, 5})});
  return fail(Status::BadArgument, fmt::format("unknown part '{}' (expected bracket, housing or lever)", name));
}

std::vector<SurfacePoint> sampleSurface(const DepthPart& part, double spacingMm) {
  std::vector<std::vector<Plane>> solids;
  for (const auto& p : part.primitives) solids.push_back(planesOf(p));
  // Sub-triangle centres, thinned on a grid of spacingMm (the point nearest each cell's
  // centre is kept), so the density is even over big faces and thin cylinder facets alike.
  std::map<std::tuple<long, long, long>, std::pair<double, SurfacePoint>> cells;
  const auto owner = ownerOfTriangles(part);
  for (std::size_t ti = 0; ti < part.mesh.triangles.size(); ++ti) {
    const auto& t = part.mesh.triangles[ti];
    const V3 a = vec(part.mesh.vertices[static_cast<std::size_t>(t[0])]);
    const V3 n = (vec(part.mesh.vertices[static_cast<std::size_t>(t[1])]) - a)
                     .cross(vec(part.mesh.vertices[static_cast<std::size_t>(t[2])]) - a)
                     .normalized();
    subdivide(part.mesh, t, spacingMm / 2, [&](const V3& p0, const V3& p1, const V3& p2) {
      const V3 p = (p0 + p1 + p2) / 3;
      if (!onExterior(solids, owner[ti], p, n)) return;
      const V3 cell = (p / spacingMm).array().floor();
      const double d = (p - (cell.array() + 0.5).matrix() * spacingMm).squaredNorm();
      const auto key = std::make_tuple(static_cast<long>(cell.x()), static_cast<long>(cell.y()), static_cast<long>(cell.z()));
      auto it = cells.find(key);
      if (it == cells.end() || d < it->second.first) cells[key] = {d, SurfacePoint{p.x(), p.y(), p.z(), n.x(), n.y(), n.z()}};
    });
  }
  std::vector<SurfacePoint> out;
  out.reserve(cells.size());
  for (const auto& [k, v] : cells) out.push_back(v.second);
  return out;
}

TriMesh exteriorMesh(const DepthPart& part, double edgeMm) {
  std::vector<std::vector<Plane>> solids;
  for (const auto& p : part.primitives) solids.push_back(planesOf(p));
  TriMesh out;
  std::map<std::tuple<long, long, long>, int> index;  // shared vertices, keyed to 1 µm
  auto vertex = [&](const V3& v) {
    const auto key = std::make_tuple(std::lround(v.x() * 1000), std::lround(v.y() * 1000), std::lround(v.z() * 1000));
    auto [it, added] = index.emplace(key, static_cast<int>(out.vertices.size()));
    if (added) out.vertices.push_back({v.x(), v.y(), v.z()});
    return it->second;
  };
  const auto owner = ownerOfTriangles(part);
  for (std::size_t ti = 0; ti < part.mesh.triangles.size(); ++ti) {
    const auto& t = part.mesh.triangles[ti];
    const V3 a = vec(part.mesh.vertices[static_cast<std::size_t>(t[0])]);
    const V3 n = (vec(part.mesh.vertices[static_cast<std::size_t>(t[1])]) - a)
                     .cross(vec(part.mesh.vertices[static_cast<std::size_t>(t[2])]) - a)
                     .normalized();
    subdivide(part.mesh, t, edgeMm, [&](const V3& p0, const V3& p1, const V3& p2) {
      if (onExterior(solids, owner[ti], (p0 + p1 + p2) / 3, n)) out.triangles.push_back({vertex(p0), vertex(p1), vertex(p2)});
    });
  }
  return out;
}

}  // namespace vgr::sim
