#include "config/job.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include "config/yaml_section.hpp"

namespace vgr::config {
namespace {

struct ImageSize {
  int width = 0, height = 0;
};

std::uint32_t bigEndian(const unsigned char* p, int n) {
  std::uint32_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

// The size of a PNG, JPEG or BMP image from its header (config links no image codec);
// nothing for any other file.
std::optional<ImageSize> imageHeaderSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  unsigned char h[32] = {};
  in.read(reinterpret_cast<char*>(h), sizeof h);
  const auto got = in.gcount();
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (got >= 24 && std::equal(kPng, kPng + 8, h) && std::string(reinterpret_cast<char*>(h + 12), 4) == "IHDR")
    return ImageSize{static_cast<int>(bigEndian(h + 16, 4)), static_cast<int>(bigEndian(h + 20, 4))};
  if (got >= 26 && h[0] == 'B' && h[1] == 'M') {
    const auto le = [&](int at) { return static_cast<std::int32_t>(h[at] | h[at + 1] << 8 | h[at + 2] << 16 | static_cast<std::uint32_t>(h[at + 3]) << 24); };
    return ImageSize{std::abs(le(18)), std::abs(le(22))};
  }
  if (got >= 4 && h[0] == 0xFF && h[1] == 0xD8) {
    // JPEG: walk the markers to the first start-of-frame (SOF0..SOF15 except DHT, JPG, DAC).
    in.clear();
    in.seekg(2);
    unsigned char m[9];
    while (in.read(reinterpret_cast<char*>(m), 4)) {
      if (m[0] != 0xFF) break;
      const int marker = m[1];
      const int length = static_cast<int>(bigEndian(m + 2, 2));
      if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
        if (!in.read(reinterpret_cast<char*>(m), 5)) break;
        return ImageSize{static_cast<int>(bigEndian(m + 3, 2)), static_cast<int>(bigEndian(m + 1, 2))};
      }
      if (length < 2) break;
      in.seekg(length - 2, std::ios::cur);
    }
  }
  return std::nullopt;
}

std::vector<TemplateRegion> parseRegions(Section& top, const YAML::Node& list) {
  std::vector<TemplateRegion> out;
  if (!list || list.IsNull()) return out;
  if (!list.IsSequence()) top.fail(list, "regions", "expected a list of {height_mm, height_factor, polygon}");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = fmt::format("regions[{}]", i);
    Section r(top.file(), list[i], path);
    TemplateRegion reg;
    reg.heightMm = r.number("height_mm", 0, 0, 1000);
    reg.heightFactor = r.number("height_factor", 1, 0, 1);
    const YAML::Node poly = r.get("polygon");
    if (!poly || !poly.IsSequence() || poly.size() < 3) r.fail(poly ? poly : list[i], "polygon", "expected a list of at least 3 points [x_px, y_px]");
    for (std::size_t k = 0; k < poly.size(); ++k) {
      const std::string key = fmt::format("polygon[{}]", k);
      if (!poly[k].IsSequence() || poly[k].size() != 2) r.fail(poly[k], key, "expected a point [x_px, y_px]");
      reg.polygon.push_back({r.numberOf(poly[k][0], key, -1e6, 1e6), r.numberOf(poly[k][1], key, -1e6, 1e6)});
    }
    r.finish(Section::UnknownKeys::Plain);
    out.push_back(std::move(reg));
  }
  return out;
}

// A grasp point must lie on the template: [0, size - 1] px (pixel centres at integers), the
// bound `vgr teach` checks.
void checkOnTemplate(const Section& s, const YAML::Node& at, const std::string& key, double v, int size, const ImageSize& t) {
  if (v < 0 || v > size - 1)
    s.fail(at, key, fmt::format("{} is outside the {}x{} px template (expected [0, {}])", v, t.width, t.height, size - 1));
}

JobFile parse(const YAML::Node& root, const std::string& file, const std::string& folder) {
  Section top(file, root, "");
  if (!root || root.IsNull()) top.fail(root, "", "the file is empty");
  JobFile j;
  j.folder = folder;
  const int version = top.integer("version", 1, 1, 1);
  (void)version;
  // `kind: 3d` jobs are read by config/job3d.hpp (and located by vision/cloud/).
  if (const std::string kind = top.text("kind", "2d"); kind == "3d")
    top.fail(top.get("kind"), "kind", "a 3D job: this reader is for 2D jobs (3D jobs: docs/3d.md)");
  else if (kind != "2d")
    top.fail(top.get("kind"), "kind", "expected 2d or 3d, got '" + kind + "'");
  j.name = top.text("name", "");
  j.method = top.text("method", j.method);
  if (j.method.empty()) top.fail(top.get("method"), "method", "must not be empty");
  j.templateImage = top.text("template", j.templateImage);

  // The template's size, for the fields given in template px, from the image's header. A
  // missing template or one that is no PNG, JPEG or BMP is left to the reader that decodes it
  // (each fails naming it: the cell config, vgrd's start, vgr locate and eval).
  std::optional<ImageSize> templ;
  if (!folder.empty()) templ = imageHeaderSize((std::filesystem::path(folder) / j.templateImage).string());

  const YAML::Node grasps = top.get("grasps");
  if (!grasps || !grasps.IsSequence() || grasps.size() == 0)
    top.fail(grasps ? grasps : root, "grasps", "expected a non-empty list of {x_px, y_px}");
  for (std::size_t i = 0; i < grasps.size(); ++i) {
    Section g(file, grasps[i], fmt::format("grasps[{}]", i));
    if (!g.has("x_px") || !g.has("y_px")) g.fail(grasps[i], "", "expected {x_px, y_px}");
    j.grasps.push_back({g.number("x_px", 0, -1e6, 1e6), g.number("y_px", 0, -1e6, 1e6)});
    if (templ) {
      checkOnTemplate(g, g.get("x_px"), "x_px", j.grasps.back().u, templ->width, *templ);
      checkOnTemplate(g, g.get("y_px"), "y_px", j.grasps.back().v, templ->height, *templ);
    }
    g.finish(Section::UnknownKeys::Plain);
  }
  j.taught.grasp = j.grasps.front();

  Section roi(file, top.get("roi"), "roi");
  j.taught.searchRoi.x = roi.integer("x", 0, 0, 65535);
  j.taught.searchRoi.y = roi.integer("y", 0, 0, 65535);
  j.taught.searchRoi.width = roi.integer("width", 0, 0, 65535);
  j.taught.searchRoi.height = roi.integer("height", 0, 0, 65535);
  {  // 0 x 0 at 0,0 is the whole image; anything else a rectangle, not silently the whole image
    const PixelRect& r = j.taught.searchRoi;
    if ((r.width == 0) != (r.height == 0))
      roi.fail(roi.get(r.width == 0 ? "width" : "height"), r.width == 0 ? "width" : "height",
               "width and height are both 0 (the whole image) or both > 0");
    if (r.width == 0 && (r.x != 0 || r.y != 0))
      roi.fail(roi.get(r.x != 0 ? "x" : "y"), r.x != 0 ? "x" : "y",
               "an offset needs width and height (0 x 0 searches the whole image)");
  }
  roi.finish(Section::UnknownKeys::Plain);

  j.taught.minScore = top.number("min_score", j.taught.minScore, 0, 1);
  j.taught.maxParts = top.integer("max_parts", j.taught.maxParts, 1, 64);
  j.taught.angleMinDeg = top.number("angle_min_deg", j.taught.angleMinDeg, -180, 180);
  j.taught.angleMaxDeg = top.number("angle_max_deg", j.taught.angleMaxDeg, -180, 180);
  if (j.taught.angleMaxDeg < j.taught.angleMinDeg) top.fail(top.get("angle_max_deg"), "angle_max_deg", "must not be below angle_min_deg");
  j.taught.scaleMin = top.number("scale_min", j.taught.scaleMin, kMinPartScale, kMaxPartScale);
  j.taught.scaleMax = top.number("scale_max", j.taught.scaleMax, kMinPartScale, kMaxPartScale);
  if (j.taught.scaleMax < j.taught.scaleMin) top.fail(top.get("scale_max"), "scale_max", "must not be below scale_min");
  j.partHeightMm = top.number("part_height_mm", 0, 0, 1000);

  j.referenceGiven = top.has("reference");
  Section ref(file, top.get("reference"), "reference");
  j.referenceXMm = ref.number("x_mm", 0, -1e6, 1e6);
  j.referenceYMm = ref.number("y_mm", 0, -1e6, 1e6);
  j.referenceZMm = ref.number("z_mm", 0, -1e6, 1e6);
  j.referenceRzDeg = ref.number("rz_deg", 0, -360, 360);
  ref.finish(Section::UnknownKeys::Plain);
  j.calibration = top.text("calibration", "");
  if (top.has("classify")) {
    Section c(file, top.get("classify"), "classify");
    c.require("model");
    j.classify.model = c.text("model", "");
    if (j.classify.model.empty()) c.fail(c.get("model"), "model", "expected a file name (the classifier YAML)");
    j.classify.minConfidence = c.number("min_confidence", j.classify.minConfidence, 0, 1);
    j.classify.maxFeatureZ = c.number("max_feature_z", j.classify.maxFeatureZ, 0, 1e6);
    j.classify.threshold = c.integer("threshold", j.classify.threshold, 0, 255);
    c.read<bool>("keep_unknown", j.classify.keepUnknown);
    c.finish(Section::UnknownKeys::Plain);
  }

  const YAML::Node params = top.get("params");
  if (params && !params.IsNull()) {
    if (!params.IsMap()) top.fail(params, "params", "expected a mapping of parameter: value");
    failOnDuplicateKeys(file, params, "params");
    for (const auto& kv : params) {
      const std::string name = kv.first.as<std::string>();
      if (!kv.second.IsScalar()) top.fail(kv.second, "params." + name, "expected a single value");
      j.taught.params[name] = kv.second.Scalar();
      j.taught.paramSources[name] = {file, kv.first.Mark().line + 1};
    }
  }
  j.taught.regions = parseRegions(top, top.get("regions"));
  if (templ) {
    // A region is a mask clipped to the template: vertices may lie outside, but a region
    // wholly outside selects no contour and is a mistake (e.g. polygons of another template).
    const YAML::Node regions = top.get("regions");
    for (std::size_t i = 0; i < j.taught.regions.size(); ++i) {
      double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
      for (const auto& p : j.taught.regions[i].polygon) {
        x0 = std::min(x0, p.u), x1 = std::max(x1, p.u), y0 = std::min(y0, p.v), y1 = std::max(y1, p.v);
      }
      if (x1 < -0.5 || y1 < -0.5 || x0 > templ->width - 0.5 || y0 > templ->height - 0.5)
        top.fail(regions[i]["polygon"], fmt::format("regions[{}].polygon", i),
                 fmt::format("lies wholly outside the {}x{} px template ([{}, {}] x [{}, {}] px)", templ->width, templ->height,
                             x0, x1, y0, y1));
    }
  }
  top.finish(Section::UnknownKeys::Plain);
  return j;
}

// A number as the shortest text that reads back to the same double (fmt's "{}"), so a
// job round-trips exactly; -0 is written 0.
std::string numberText(double v) { return v == 0 ? std::string("0") : fmt::format("{}", v); }

// {x_px: U, y_px: V}, on one line.
void emitPoint(YAML::Emitter& y, const PixelPoint& p) {
  y << YAML::Flow << YAML::BeginMap << YAML::Key << "x_px" << YAML::Value << numberText(p.u) << YAML::Key << "y_px"
    << YAML::Value << numberText(p.v) << YAML::EndMap;
}

}  // namespace

std::string JobFile::templatePath() const { return (std::filesystem::path(folder) / templateImage).string(); }
std::string JobFile::calibrationPath() const {
  return calibration.empty() ? std::string() : (std::filesystem::path(folder) / calibration).string();
}
std::string JobFile::classifierPath() const {
  return classify.model.empty() ? std::string() : (std::filesystem::path(folder) / classify.model).string();
}

Result<JobFile> parseJob(const std::string& text, const std::string& sourceName, const std::string& folder) {
  try {
    failOnInvalidUtf8(sourceName, text);
    return parse(YAML::Load(text), sourceName, folder);
  } catch (const SectionError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}:{}: YAML syntax error: {}", sourceName, e.mark.line + 1, e.msg));
  }
}

Result<JobFile> loadJob(const std::string& folder) {
  const std::string path = (std::filesystem::path(folder) / "job.yaml").string();
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the job file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseJob(ss.str(), path, folder);
}

std::string jobYaml(const JobFile& j) {
  YAML::Emitter y;
  y << YAML::Comment("vgr job (docs/localization.md \"Jobs\"). Pixels: template px, x right, y down,\n"
                     "pixel centres at integers; angles in degrees, counter-clockwise as displayed.");
  y << YAML::BeginMap;
  y << YAML::Key << "version" << YAML::Value << 1;
  y << YAML::Key << "name" << YAML::Value << j.name;
  y << YAML::Key << "method" << YAML::Value << j.method;
  y << YAML::Key << "template" << YAML::Value << j.templateImage;
  y << YAML::Key << "grasps" << YAML::Comment("the first is the one transferred into live images") << YAML::Value
    << YAML::BeginSeq;
  for (const auto& g : j.grasps) emitPoint(y, g);
  y << YAML::EndSeq;
  const auto& r = j.taught.searchRoi;
  y << YAML::Key << "roi" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x" << YAML::Value << r.x
    << YAML::Key << "y" << YAML::Value << r.y << YAML::Key << "width" << YAML::Value << r.width << YAML::Key << "height"
    << YAML::Value << r.height << YAML::EndMap << YAML::Comment("search region in live images; 0 x 0 = whole image");
  y << YAML::Key << "min_score" << YAML::Value << numberText(j.taught.minScore)
    << YAML::Comment("[0, 1]: weaker candidates are not parts");
  y << YAML::Key << "max_parts" << YAML::Value << j.taught.maxParts << YAML::Comment("[1, 64]");
  y << YAML::Key << "angle_min_deg" << YAML::Value << numberText(j.taught.angleMinDeg);
  y << YAML::Key << "angle_max_deg" << YAML::Value << numberText(j.taught.angleMaxDeg);
  y << YAML::Key << "scale_min" << YAML::Value << numberText(j.taught.scaleMin);
  y << YAML::Key << "scale_max" << YAML::Value << numberText(j.taught.scaleMax)
    << YAML::Comment("image px per template px; a part seen larger is nearer the camera");
  y << YAML::Key << "part_height_mm" << YAML::Value << numberText(j.partHeightMm)
    << YAML::Comment("grasp height above the conveyor plane");
  y << YAML::Key << "reference" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_mm" << YAML::Value
    << numberText(j.referenceXMm) << YAML::Key << "y_mm" << YAML::Value << numberText(j.referenceYMm) << YAML::Key
    << "z_mm" << YAML::Value << numberText(j.referenceZMm) << YAML::Key << "rz_deg" << YAML::Value
    << numberText(j.referenceRzDeg) << YAML::EndMap << YAML::Comment("taught robot pose (base frame)");
  y << YAML::Key << "calibration" << YAML::Value << j.calibration
    << YAML::Comment("a cell config whose model maps px -> mm; empty = pixels only");
  if (!j.classify.model.empty()) {
    // Only when set, so jobs without a classifier are written exactly as before.
    y << YAML::Key << "classify" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "model" << YAML::Value
      << j.classify.model << YAML::Key << "min_confidence" << YAML::Value << numberText(j.classify.minConfidence)
      << YAML::Key << "max_feature_z" << YAML::Value << numberText(j.classify.maxFeatureZ) << YAML::Key << "threshold"
      << YAML::Value << j.classify.threshold << YAML::Key << "keep_unknown" << YAML::Value << j.classify.keepUnknown
      << YAML::EndMap
      << YAML::Comment("part classifier (docs/classification.md); unsure parts dropped unless keep_unknown");
  }
  y << YAML::Newline << YAML::Comment("The method's parameters by name (docs/localization.md); unknown names are an error.");
  y << YAML::Key << "params" << YAML::Value;
  if (j.taught.params.empty()) y << YAML::Flow;
  y << YAML::BeginMap;
  for (const auto& [k, v] : j.taught.params) y << YAML::Key << k << YAML::Value << v;
  y << YAML::EndMap;
  y << YAML::Newline
    << YAML::Comment("Contour regions of paper 000 (eqs. 3-4): top faces in template px with their height and\n"
                     "height factor (1 at the grasp point's height, far less than 1 elsewhere). Edit freely.");
  y << YAML::Key << "regions" << YAML::Value;
  if (j.taught.regions.empty()) y << YAML::Flow;
  y << YAML::BeginSeq;
  for (const auto& reg : j.taught.regions) {
    y << YAML::BeginMap << YAML::Key << "height_mm" << YAML::Value << numberText(reg.heightMm) << YAML::Key
      << "height_factor" << YAML::Value << numberText(reg.heightFactor) << YAML::Key << "polygon" << YAML::Value
      << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : reg.polygon) y << YAML::BeginSeq << numberText(p.u) << numberText(p.v) << YAML::EndSeq;
    y << YAML::EndSeq << YAML::EndMap;
  }
  y << YAML::EndSeq << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

Result<void> writeJob(const JobFile& j) { return writeTextFile((std::filesystem::path(j.folder) / "job.yaml").string(), jobYaml(j)); }

Result<std::vector<TemplateRegion>> loadRegions(const std::string& path) {
  return readYamlFile<std::vector<TemplateRegion>>(path, [&](const YAML::Node& root) {
    if (!root.IsMap()) throw SectionError{path + ": expected a mapping with a 'regions' list"};
    Section top(path, root, "");
    return parseRegions(top, top.get("regions"));
  });
}

std::string partTemplateYaml(const PartTemplateFile& t) {
  YAML::Emitter y;
  y << YAML::Comment(fmt::format(
      "Template of the rendered part (vgr sim render, vgr demo): alone under the optical axis, rz = 0.\n"
      "Teach a job on it: vgr teach --image {} --grasp {:.3f},{:.3f} --regions template.yaml --out JOB",
      t.image, t.grasp.u, t.grasp.v));
  y << YAML::BeginMap;
  y << YAML::Key << "image" << YAML::Value << t.image;
  y << YAML::Key << "grasp" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_px" << YAML::Value
    << fmt::format("{:.4f}", t.grasp.u) << YAML::Key << "y_px" << YAML::Value << fmt::format("{:.4f}", t.grasp.v)
    << YAML::EndMap << YAML::Comment("template px, pixel centres at integers, y down");
  y << YAML::Key << "grasp_height_mm" << YAML::Value << fmt::format("{:.3f}", t.graspHeightMm);
  y << YAML::Key << "crop_offset" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_px" << YAML::Value
    << t.cropOffsetX << YAML::Key << "y_px" << YAML::Value << t.cropOffsetY << YAML::EndMap
    << YAML::Comment("template px + offset = px of the full image");
  y << YAML::Newline
    << YAML::Comment("Top faces of the part's levels in template px (paper 000's contour regions); height_factor\n"
                     "1 at the grasp point's height, 0.1 elsewhere (paper 000, eq. 4: far less than 1).");
  y << YAML::Key << "regions" << YAML::Value;
  if (t.regions.empty()) y << YAML::Flow;
  y << YAML::BeginSeq;
  for (const auto& r : t.regions) {
    y << YAML::BeginMap << YAML::Key << "height_mm" << YAML::Value << fmt::format("{:.3f}", r.heightMm) << YAML::Key
      << "height_factor" << YAML::Value << numberText(r.heightFactor) << YAML::Key << "polygon" << YAML::Value
      << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : r.polygon) y << YAML::BeginSeq << fmt::format("{:.2f}", p.u) << fmt::format("{:.2f}", p.v) << YAML::EndSeq;
    y << YAML::EndSeq << YAML::EndMap;
  }
  y << YAML::EndSeq << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

Result<void> writePartTemplateFile(const std::string& path, const PartTemplateFile& t) {
  return writeTextFile(path, partTemplateYaml(t));
}

Result<PartTemplateFile> loadPartTemplateFile(const std::string& path) {
  return readYamlFile<PartTemplateFile>(path, [&](const YAML::Node& root) {
    Section top(path, root, "");
    if (!root || root.IsNull()) top.fail(root, "", "the file is empty");
    PartTemplateFile t;
    t.image = top.text("image", t.image);
    Section grasp(path, top.get("grasp"), "grasp");
    t.grasp = {grasp.number("x_px", 0, -1e6, 1e6), grasp.number("y_px", 0, -1e6, 1e6)};
    grasp.finish();
    t.graspHeightMm = top.number("grasp_height_mm", 0, 0, 1000);
    Section crop(path, top.get("crop_offset"), "crop_offset");
    t.cropOffsetX = crop.integer("x_px", 0, -65535, 65535);
    t.cropOffsetY = crop.integer("y_px", 0, -65535, 65535);
    crop.finish();
    t.regions = parseRegions(top, top.get("regions"));
    top.finish();
    return t;
  });
}

}  // namespace vgr::config
