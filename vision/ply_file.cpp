#include "vision/ply_file.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/core.h>

namespace vgr::vision {
namespace {

struct Element {
  std::string name;
  long count = 0;
  std::vector<std::string> properties;  // scalar property names, in order
  bool faceList = false;                // "property list <count type> <index type> vertex_indices"
  int line = 0;
};

struct Header {
  std::vector<Element> elements;
  int dataLine = 0;  // line number of the first data line
};

std::vector<std::string> split(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

Result<Header> readHeader(std::istream& in, const std::string& path) {
  Header h;
  std::string line;
  int n = 0;
  auto bad = [&](const std::string& what) { return fail(Status::BadArgument, fmt::format("{}:{}: {}", path, n, what)); };
  if (!std::getline(in, line)) return fail(Status::BadArgument, path + ": empty file (expected a PLY header)");
  ++n;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != "ply") return bad("not a PLY file (the first line must be 'ply')");
  bool format = false;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto w = split(line);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() < 2 || w[1] != "ascii")
        return bad(fmt::format("format '{}': only ASCII PLY is read (save it as ASCII)", w.size() > 1 ? w[1] : ""));
      format = true;
    } else if (w[0] == "element") {
      if (w.size() != 3) return bad("expected 'element NAME COUNT'");
      long count = -1;
      const auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), count);
      if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size() || count < 0) return bad("element count '" + w[2] + "' is not a count");
      h.elements.push_back({w[1], count, {}, false, n});
    } else if (w[0] == "property") {
      if (h.elements.empty()) return bad("property before any element");
      if (w.size() >= 2 && w[1] == "list") {
        if (w.size() != 5) return bad("expected 'property list COUNT_TYPE INDEX_TYPE NAME'");
        h.elements.back().faceList = true;
        h.elements.back().properties.push_back(w[4]);
      } else {
        if (w.size() != 3) return bad("expected 'property TYPE NAME'");
        h.elements.back().properties.push_back(w[2]);
      }
    } else if (w[0] == "end_header") {
      if (!format) return bad("end_header before a 'format ascii 1.0' line");
      h.dataLine = n + 1;
      return h;
    } else {
      return bad("unknown header line '" + line + "'");
    }
  }
  return fail(Status::BadArgument, path + ": no end_header line");
}

int indexOf(const Element& e, const std::string& name) {
  for (std::size_t i = 0; i < e.properties.size(); ++i)
    if (e.properties[i] == name) return static_cast<int>(i);
  return -1;
}

bool parseDouble(const std::string& s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(v);
}

struct Parsed {
  PlyCloud cloud;
  std::vector<std::array<int, 3>> triangles;
};

Result<Parsed> readPly(const std::string& path, bool wantFaces) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open");
  auto header = readHeader(in, path);
  if (!header) return std::unexpected(header.error());
  Parsed out;
  int n = header->dataLine - 1;
  bool sawVertex = false;
  for (const auto& e : header->elements) {
    auto bad = [&](const std::string& what) { return fail(Status::BadArgument, fmt::format("{}:{}: {}", path, n, what)); };
    const bool isVertex = e.name == "vertex";
    const bool isFace = e.name == "face";
    const int ix = indexOf(e, "x"), iy = indexOf(e, "y"), iz = indexOf(e, "z");
    const int inx = indexOf(e, "nx"), iny = indexOf(e, "ny"), inz = indexOf(e, "nz");
    if (isVertex) {
      sawVertex = true;
      if (ix < 0 || iy < 0 || iz < 0)
        return fail(Status::BadArgument, fmt::format("{}:{}: element vertex has no x, y and z properties", path, e.line));
    }
    const bool normals = isVertex && inx >= 0 && iny >= 0 && inz >= 0;
    std::string line;
    for (long i = 0; i < e.count; ++i) {
      if (!std::getline(in, line)) return bad(fmt::format("the file ends after {} of {} {} lines", i, e.count, e.name));
      ++n;
      const auto w = split(line);
      if (isVertex) {
        if (w.size() != e.properties.size()) return bad(fmt::format("expected {} numbers, got {}", e.properties.size(), w.size()));
        std::array<double, 3> p{}, nn{};
        for (int k = 0; k < 3; ++k)
          if (!parseDouble(w[static_cast<std::size_t>((k == 0 ? ix : k == 1 ? iy : iz))], p[static_cast<std::size_t>(k)]))
            return bad("a coordinate is not a finite number");
        out.cloud.points.push_back(p);
        if (normals) {
          for (int k = 0; k < 3; ++k)
            if (!parseDouble(w[static_cast<std::size_t>((k == 0 ? inx : k == 1 ? iny : inz))], nn[static_cast<std::size_t>(k)]))
              return bad("a normal component is not a finite number");
          const double len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
          if (len < 1e-6) return bad("zero normal");
          out.cloud.normals.push_back({nn[0] / len, nn[1] / len, nn[2] / len});
        }
      } else if (isFace && wantFaces) {
        if (!e.faceList) return fail(Status::BadArgument, fmt::format("{}:{}: element face has no vertex index list", path, e.line));
        if (w.size() != 4 || w[0] != "3") return bad("expected a triangle: '3 A B C'");
        std::array<int, 3> t{};
        for (int k = 0; k < 3; ++k) {
          const auto& s = w[static_cast<std::size_t>(k + 1)];
          const auto r = std::from_chars(s.data(), s.data() + s.size(), t[static_cast<std::size_t>(k)]);
          if (r.ec != std::errc() || r.ptr != s.data() + s.size() || t[static_cast<std::size_t>(k)] < 0 ||
              t[static_cast<std::size_t>(k)] >= static_cast<int>(out.cloud.points.size()))
            return bad(fmt::format("vertex index '{}' is not one of the {} vertices", s, out.cloud.points.size()));
        }
        out.triangles.push_back(t);
      }
    }
  }
  if (!sawVertex) return fail(Status::BadArgument, path + ": no 'element vertex' in the header");
  return out;
}

std::string num(double v) {
  std::string s = fmt::format("{:.4f}", v);
  return s == "-0.0000" ? "0.0000" : s;
}

}  // namespace

Result<PlyCloud> readPlyCloud(const std::string& path) {
  auto p = readPly(path, false);
  if (!p) return std::unexpected(p.error());
  return std::move(p->cloud);
}

Result<PlyMesh> readPlyMesh(const std::string& path) {
  auto p = readPly(path, true);
  if (!p) return std::unexpected(p.error());
  if (p->triangles.empty()) return fail(Status::BadArgument, path + ": no triangles (expected an 'element face' of triangles)");
  return PlyMesh{std::move(p->cloud.points), std::move(p->triangles)};
}

Result<void> writePlyCloud(const std::string& path, const PlyCloud& c, const std::string& comment) {
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\n";
  if (!comment.empty()) out << "comment " << comment << "\n";
  out << "element vertex " << c.points.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (c.hasNormals()) out << "property float nx\nproperty float ny\nproperty float nz\n";
  out << "end_header\n";
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    const auto& p = c.points[i];
    out << num(p[0]) << ' ' << num(p[1]) << ' ' << num(p[2]);
    if (c.hasNormals()) {
      const auto& n = c.normals[i];
      out << fmt::format(" {:.6f} {:.6f} {:.6f}", n[0], n[1], n[2]);
    }
    out << '\n';
  }
  out.close();
  if (!out) return fail(Status::Internal, path + ": cannot write");
  return {};
}

Result<void> writePlyMesh(const std::string& path, const PlyMesh& m, const std::string& comment) {
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\n";
  if (!comment.empty()) out << "comment " << comment << "\n";
  out << "element vertex " << m.vertices.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  out << "element face " << m.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& p : m.vertices) out << num(p[0]) << ' ' << num(p[1]) << ' ' << num(p[2]) << '\n';
  for (const auto& t : m.triangles) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  out.close();
  if (!out) return fail(Status::Internal, path + ": cannot write");
  return {};
}

}  // namespace vgr::vision
