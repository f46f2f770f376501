// The one reader of YAML mappings for config/ (cell config, job.yaml, regions lists):
// walks one mapping, remembers which keys were read and rejects the rest, so a typo in a
// key is an error naming the line, never a silently ignored setting. Every error reads
//   "FILE:LINE: key 'PATH.KEY': WHAT"
// (LINE 1-based, 0 when the node has no position; PATH as "robots[1].strict").
// Private to the config target (yaml-cpp does not leak out of config/): parsers throw
// SectionError inside and turn it into an Error at their API boundary.
#pragma once

#include <cmath>
#include <functional>
#include <set>
#include <string>
#include <type_traits>

#include <yaml-cpp/yaml.h>

#include "core/result.hpp"

namespace vgr::config {

// Thrown by Section::fail(); caught by the parser's public function.
struct SectionError {
  std::string message;
};

// Throws "FILE:LINE: key 'PATH.KEY': duplicate key (first given on line N)" when `map` holds
// a key twice (yaml-cpp would answer the first value and drop the second silently). Every
// Section checks its mapping; call it for a mapping read without one (e.g. `params`).
void failOnDuplicateKeys(const std::string& file, const YAML::Node& map, const std::string& path);

// Throws "FILE:LINE: not UTF-8 text: byte 0xE9 at column C (save the file as UTF-8)" for
// the first byte sequence in `text` that is not valid UTF-8 (yaml-cpp would pass it on
// silently, a Latin-1 name reaching the robot or the journal as garbage).
void failOnInvalidUtf8(const std::string& file, const std::string& text);

class Section {
 public:
  // node: the mapping (absent or null = empty, a key given twice = an error); path: its key
  // path ("" at the top).
  Section(std::string file, YAML::Node node, std::string path);

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const;
  // "path.key"; a key starting with '[' is an index: "path[2]".
  std::string join(const std::string& key) const;

  // Marks `key` as known; the node, absent when the key is.
  YAML::Node get(const std::string& key);
  // Present and not null.
  bool has(const std::string& key);
  void require(const std::string& key);

  // Cell-config style: keeps `out` when absent or null; a value that does not convert is
  // "expected <type>[ in <range>], got 'x'", one `valid` refuses "out of range: expected
  // <range>, got 'x'".
  template <class T>
  void read(const std::string& key, T& out, std::function<bool(const T&)> valid = nullptr,
            const std::string& range = "") {
    YAML::Node n = get(key);
    if (!n || n.IsNull()) return;  // absent or empty: keep the default
    T v{};
    try {
      v = n.as<T>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected " + typeName<T>() + (range.empty() ? "" : " in " + range) + ", got '" + scalar(n) + "'");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) fail(n, key, "expected a finite number, got '" + scalar(n) + "'");
    }
    if (valid && !valid(v)) fail(n, key, "out of range: expected " + range + ", got '" + scalar(n) + "'");
    out = v;
  }

  // job.yaml style: `fallback` when absent or null; any bad value is
  // "expected a number in [lo, hi], got 'x'" (resp. "an integer").
  double number(const std::string& key, double fallback, double lo, double hi);
  double numberOf(const YAML::Node& n, const std::string& key, double lo, double hi) const;
  int integer(const std::string& key, int fallback, int lo, int hi);
  // A scalar as written, `fallback` when absent or null.
  std::string text(const std::string& key, const std::string& fallback);

  enum class UnknownKeys {
    Suggest,  // "unknown key (did you mean 'port'?)" when a read key is within 2 edits
    Plain,    // "unknown key"
  };
  // After all reads: the first key not read is an error.
  void finish(UnknownKeys style = UnknownKeys::Suggest) const;

  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

  // A scalar's text, "<non-scalar>" for anything else (for error messages).
  static std::string scalar(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : std::string("<non-scalar>"); }

 private:
  template <class T>
  static std::string typeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return "an integer";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else return "a string";
  }

  std::string file_;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> known_;
};

// Runs `parse` on the YAML file at `path`; SectionError, a file that cannot be opened
// ("PATH: cannot open") and syntax errors ("PATH:LINE: YAML syntax error: ...") become
// Status::BadArgument errors.
template <class T>
Result<T> readYamlFile(const std::string& path, const std::function<T(const YAML::Node&)>& parse) {
  try {
    return parse(YAML::LoadFile(path));
  } catch (const SectionError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::BadFile&) {
    return fail(Status::BadArgument, path + ": cannot open");
  } catch (const YAML::Exception& e) {
    return fail(Status::BadArgument, path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

// Writes `text` to `path`, replacing it; Status::Internal "PATH: cannot write" on failure.
Result<void> writeTextFile(const std::string& path, const std::string& text);

}  // namespace vgr::config
