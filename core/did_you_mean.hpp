// "Did you mean ...?" for names typed by people (YAML keys, method parameters): the known
// name closest to a misspelt one. Pure functions, no state.
#pragma once

#include <cstddef>
#include <set>
#include <string>

namespace vgr {

// Levenshtein distance (insertions, deletions, substitutions) between a and b.
std::size_t editDistance(const std::string& a, const std::string& b);

// The first of `known` (in set order) at the smallest distance from `name` when that
// distance is at most maxEdits; empty when none is that close.
std::string closestName(const std::string& name, const std::set<std::string>& known, std::size_t maxEdits = 2);

}  // namespace vgr
