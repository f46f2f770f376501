// Reads a method's parameters (TaughtTemplate::params, strings from job.yaml) with range
// checks, so every method reports a bad or unknown parameter the same way:
//   "orb-adk: parameter 'mu': expected a number in [1, 20], got 'abc'"
// followed, when the job reader recorded where the parameter was written
// (TaughtTemplate::paramSources), by that place in the job reader's shape:
//   " (JOB/job.yaml:9: key 'params.mu')".
// An unknown name is "hu: unknown parameter 'treshold'", with " (did you mean 'threshold'?)"
// when a name the method reads is within 2 edits (core/did_you_mean.hpp, as the cell config).
// Usage: ParamReader r("hu", taught); x = r.number("threshold", 0, 0, 255); ...;
//        if (auto e = r.finish(); !e) return std::unexpected(e.error());
// The reader borrows the maps it is given: they must outlive it.
#pragma once

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/result.hpp"
#include "core/taught_template.hpp"

namespace vgr::vision {

class ParamReader {
 public:
  ParamReader(std::string method, const TaughtTemplate& taught)
      : ParamReader(std::move(method), taught.params, taught.paramSources) {}
  ParamReader(std::string method, const std::map<std::string, std::string>& params,
              const std::map<std::string, ParamSource>& sources)
      : method_(std::move(method)), params_(params), sources_(sources) {}

  // The parameter as a number in [lo, hi], or `fallback` when absent.
  double number(const std::string& name, double fallback, double lo, double hi);
  // The parameter as an integer in [lo, hi], or `fallback` when absent.
  int integer(const std::string& name, int fallback, int lo, int hi);
  // The parameter as a boolean (true/false), or `fallback` when absent.
  bool flag(const std::string& name, bool fallback);
  // The parameter as one of `allowed` (a word, e.g. polarity), or `fallback` when absent.
  std::string word(const std::string& name, const std::string& fallback, const std::vector<std::string>& allowed);

  // The first error met, or an error naming a parameter nobody asked for (a typo in job.yaml).
  Result<void> finish() const;

  // " (FILE:LINE: key 'params.NAME')" where the parameter was written, "" when unknown: for
  // a method's own checks of a parameter (e.g. a word ParamReader does not read).
  std::string whereWritten(const std::string& name) const;

 private:
  void setError(const std::string& name, const std::string& expected, const std::string& got);

  std::string method_;
  const std::map<std::string, std::string>& params_;
  const std::map<std::string, ParamSource>& sources_;
  std::set<std::string> used_;
  std::string error_;
};

}  // namespace vgr::vision
