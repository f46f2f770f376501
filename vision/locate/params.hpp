// Reads a method's parameters (TaughtTemplate::params, strings from job.yaml) with range
// checks, so every method reports a bad or unknown parameter the same way:
//   "orb-adk: parameter 'mu': expected a number in [1, 20], got 'abc'".
// Usage: ParamReader r("hu", taught.params); x = r.number("threshold", 0, 0, 255); ...;
//        if (auto e = r.finish(); !e) return std::unexpected(e.error());
#pragma once

#include <map>
#include <set>
#include <utility>
#include <string>

#include "core/result.hpp"

namespace vgr::vision {

class ParamReader {
 public:
  ParamReader(std::string method, const std::map<std::string, std::string>& params)
      : method_(std::move(method)), params_(params) {}

  // The parameter as a number in [lo, hi], or `fallback` when absent.
  double number(const std::string& name, double fallback, double lo, double hi);
  // The parameter as an integer in [lo, hi], or `fallback` when absent.
  int integer(const std::string& name, int fallback, int lo, int hi);
  // The parameter as a boolean (true/false), or `fallback` when absent.
  bool flag(const std::string& name, bool fallback);

  // The first error met, or an error naming a parameter nobody asked for (a typo in job.yaml).
  Result<void> finish() const;

 private:
  void setError(const std::string& name, const std::string& expected, const std::string& got);

  std::string method_;
  const std::map<std::string, std::string>& params_;
  std::set<std::string> used_;
  std::string error_;
};

}  // namespace vgr::vision
