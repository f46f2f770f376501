#include "core/did_you_mean.hpp"

#include <algorithm>
#include <utility>
#include <vector>

namespace vgr {

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0u : 1u)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string closestName(const std::string& name, const std::set<std::string>& known, std::size_t maxEdits) {
  std::string best;
  std::size_t bestD = maxEdits + 1;
  for (const auto& cand : known) {
    const std::size_t d = editDistance(name, cand);
    if (d < bestD) bestD = d, best = cand;
  }
  return best;
}

}  // namespace vgr
