#include "config/yaml_section.hpp"

#include <cstdint>
#include <fstream>
#include <map>
#include <utility>

#include <fmt/core.h>

#include "core/did_you_mean.hpp"

namespace vgr::config {

Section::Section(std::string file, YAML::Node node, std::string path)
    : file_(std::move(file)), node_(std::move(node)), path_(std::move(path)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) fail(node_, "", "expected a mapping");
  if (node_ && node_.IsMap()) failOnDuplicateKeys(file_, node_, path_);
}

void failOnInvalidUtf8(const std::string& file, const std::string& text) {
  int line = 1;
  std::size_t lineStart = 0;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      lineStart = ++i;
      continue;
    }
    int extra = c < 0x80 ? 0 : (c >> 5) == 0x6 ? 1 : (c >> 4) == 0xE ? 2 : (c >> 3) == 0x1E ? 3 : -1;
    bool ok = extra >= 0 && i + extra < text.size();
    for (int k = 1; ok && k <= extra; ++k) ok = (static_cast<unsigned char>(text[i + k]) >> 6) == 0x2;
    // Overlong forms, surrogates and code points above U+10FFFF are not UTF-8 either.
    if (ok && extra > 0) {
      std::uint32_t cp = c & (0x3F >> extra);
      for (int k = 1; k <= extra; ++k) cp = (cp << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3F);
      static const std::uint32_t kMin[4] = {0, 0x80, 0x800, 0x10000};
      ok = cp >= kMin[extra] && cp <= 0x10FFFF && (cp < 0xD800 || cp > 0xDFFF);
    }
    if (!ok)
      throw SectionError{fmt::format("{}:{}: not UTF-8 text: byte 0x{:02X} at column {} (save the file as UTF-8)", file, line,
                                     c, i - lineStart + 1)};
    i += static_cast<std::size_t>(extra) + 1;
  }
}

void failOnDuplicateKeys(const std::string& file, const YAML::Node& map, const std::string& path) {
  // yaml-cpp keeps every entry of a mapping and node[key] answers the first: a key written
  // twice would silently lose its second value.
  std::map<std::string, int> seen;  // key -> 1-based line of its first entry
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) continue;
    const std::string k = kv.first.Scalar();
    const int line = kv.first.Mark().line >= 0 ? kv.first.Mark().line + 1 : 0;
    const auto [at, fresh] = seen.emplace(k, line);
    if (!fresh) {
      const std::string full = path.empty() ? k : path + "." + k;
      throw SectionError{fmt::format("{}:{}: key '{}': duplicate key (first given on line {})", file, line, full, at->second)};
    }
  }
}

void Section::fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
  const int line = at.Mark().line >= 0 ? at.Mark().line + 1 : 0;
  throw SectionError{fmt::format("{}:{}: key '{}': {}", file_, line, join(key), what)};
}

std::string Section::join(const std::string& key) const {
  if (path_.empty()) return key;
  if (key.empty()) return path_;
  return key.front() == '[' ? path_ + key : path_ + "." + key;
}

YAML::Node Section::get(const std::string& key) {
  known_.insert(key);
  if (!node_ || !node_.IsMap()) return YAML::Node();
  return node_[key];
}

bool Section::has(const std::string& key) {
  const YAML::Node n = get(key);
  return n && !n.IsNull();
}

void Section::require(const std::string& key) {
  if (!node_ || !node_.IsMap() || !node_[key]) fail(node_, key, "required key is missing");
}

double Section::number(const std::string& key, double fallback, double lo, double hi) {
  const YAML::Node n = get(key);
  if (!n || n.IsNull()) return fallback;
  return numberOf(n, key, lo, hi);
}

double Section::numberOf(const YAML::Node& n, const std::string& key, double lo, double hi) const {
  double v = 0;
  try {
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(n, key, fmt::format("expected a number in [{}, {}], got '{}'", lo, hi, scalar(n)));
  }
  if (!std::isfinite(v) || v < lo || v > hi) fail(n, key, fmt::format("expected a number in [{}, {}], got '{}'", lo, hi, scalar(n)));
  return v;
}

int Section::integer(const std::string& key, int fallback, int lo, int hi) {
  const YAML::Node n = get(key);
  if (!n || n.IsNull()) return fallback;
  int v = 0;
  try {
    v = n.as<int>();
  } catch (const YAML::Exception&) {
    fail(n, key, fmt::format("expected an integer in [{}, {}], got '{}'", lo, hi, scalar(n)));
  }
  if (v < lo || v > hi) fail(n, key, fmt::format("expected an integer in [{}, {}], got '{}'", lo, hi, scalar(n)));
  return v;
}

std::string Section::text(const std::string& key, const std::string& fallback) {
  const YAML::Node n = get(key);
  if (!n || n.IsNull()) return fallback;
  if (!n.IsScalar()) fail(n, key, "expected a string");
  return n.Scalar();
}

void Section::finish(UnknownKeys style) const {
  if (!node_ || !node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.as<std::string>();
    if (known_.count(k)) continue;
    const std::string best = style == UnknownKeys::Suggest ? closestName(k, known_) : std::string();
    fail(kv.first, k, best.empty() ? "unknown key" : "unknown key (did you mean '" + best + "'?)");
  }
}

Result<void> writeTextFile(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) return fail(Status::Internal, path + ": cannot write");
  return {};
}

}  // namespace vgr::config
