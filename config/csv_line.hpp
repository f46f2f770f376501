// One line of the data sets' CSV files (truth.csv, views.csv, grasps.csv): the fields
// between commas, a trailing '\r' (a file saved on Windows) dropped. No quoting: the fixed
// formats' fields never hold a comma (docs/datasets.md, docs/3d.md). Pure, any thread.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace vgr::config {

inline std::vector<std::string> splitCsvLine(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::vector<std::string> out(1);
  for (char c : line) {
    if (c == ',') out.emplace_back();
    else out.back() += c;
  }
  return out;
}

}  // namespace vgr::config
