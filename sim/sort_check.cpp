#include "sim/sort_check.hpp"

#include <cmath>
#include <fstream>
#include <limits>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

namespace vgr::sim {
namespace {

// Index of the part of `parts` nearest (x, y) within kMatchMm, -1 when none is.
template <class Part>
int nearest(const std::vector<Part>& parts, double x, double y, double& dist) {
  int best = -1;
  dist = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const double d = std::hypot(parts[i].xMm - x, parts[i].yMm - y);
    if (d <= kMatchMm && d < dist) dist = d, best = static_cast<int>(i);
  }
  return best;
}

void note(SortCheck& c, const std::string& what) {
  if (c.firstProblem.empty()) c.firstProblem = what;
}

}  // namespace

const char* partOrderName(config::PartOrder order) {
  switch (order) {
    case config::PartOrder::BestScore: return "best_score";
    case config::PartOrder::ByLabel: return "by_label";
    case config::PartOrder::LabelOnly: return "label_only";
    case config::PartOrder::Random: return "random";
  }
  return "?";
}

SortCheck checkSorting(config::PartOrder order, int label, const std::map<std::uint64_t, std::vector<CellPartTruth>>& truth,
                       const std::map<std::uint32_t, JournalCycle>& journal, const std::vector<RobotGot>& got) {
  std::map<std::uint32_t, std::vector<RobotGot>> byCycle;
  for (const RobotGot& g : got)
    if (g.status == 0 || g.status == 1) byCycle[g.cycle].push_back(g);

  SortCheck c;
  for (const auto& [cycle, jc] : journal) {
    if (jc.status != 0 && jc.status != 1) continue;  // an error result: nothing to sort
    ++c.cycles;
    const auto seen = byCycle.find(cycle);
    const auto frame = truth.find(jc.frameId);
    if (seen == byCycle.end() || frame == truth.end()) {
      ++c.unseen;
      note(c, seen == byCycle.end() ? fmt::format("cycle {}: no reply", cycle)
                                    : fmt::format("cycle {}: frame {} has no truth line", cycle, jc.frameId));
      continue;
    }
    // What this robot's order serves of the frame.
    std::vector<CellPartTruth> served;
    for (const auto& t : frame->second)
      if (order != config::PartOrder::LabelOnly || t.label == label) served.push_back(t);
    std::vector<RobotGot> ok;
    bool noPart = false;
    for (const auto& g : seen->second) (g.status == 0 ? ok.push_back(g) : void(noPart = true));
    c.expected += static_cast<int>(served.size());
    c.delivered += static_cast<int>(ok.size());
    if (served.empty() && !noPart) {
      ++c.missingNoPart;
      note(c, fmt::format("cycle {}: nothing to serve, but no NO_PART_FOUND reply", cycle));
    }
    std::vector<int> times(served.size(), 0);
    int lastIndex = -1, lastLabel = std::numeric_limits<int>::min();
    for (const RobotGot& g : ok) {
      double d = 0;
      const int j = nearest(served, g.xMm, g.yMm, d);
      if (j < 0) {
        double any = 0;
        if (nearest(frame->second, g.xMm, g.yMm, any) >= 0) {
          ++c.wrongLabel;  // a truth part, but not one of this order's label
          note(c, fmt::format("cycle {}: got a part of another label than {} (reply label {})", cycle, label, g.label));
        } else {
          ++c.extra;
          note(c, fmt::format("cycle {}: got a part at ({:.1f}, {:.1f}) mm that is no truth part", cycle, g.xMm, g.yMm));
        }
        continue;
      }
      c.maxPosErrMm = std::max(c.maxPosErrMm, d);
      if (++times[static_cast<std::size_t>(j)] > 1) {
        ++c.duplicates;
        note(c, fmt::format("cycle {}: a part was delivered twice", cycle));
      }
      if (g.label != served[static_cast<std::size_t>(j)].label) {
        ++c.wrongLabel;
        note(c, fmt::format("cycle {}: label {} for a part of label {}", cycle, g.label, served[static_cast<std::size_t>(j)].label));
      }
      // The sequence: the journal's order (best first), by label first for by_label.
      double jd = 0;
      const int index = nearest(jc.parts, g.xMm, g.yMm, jd);
      bool inOrder = true;
      if (order == config::PartOrder::ByLabel)
        inOrder = g.label > lastLabel || (g.label == lastLabel && index > lastIndex);
      else if (order != config::PartOrder::Random)
        inOrder = index > lastIndex;
      if (!inOrder) {
        ++c.outOfOrder;
        note(c, fmt::format("cycle {}: part out of {} order", cycle, partOrderName(order)));
      }
      lastIndex = index;
      lastLabel = g.label;
    }
    for (std::size_t j = 0; j < served.size(); ++j)
      if (times[j] == 0) {
        ++c.missed;
        note(c, fmt::format("cycle {}: the part of label {} at ({:.1f}, {:.1f}) mm was not delivered", cycle, served[j].label,
                            served[j].xMm, served[j].yMm));
      }
  }
  if (c.cycles == 0) note(c, "no cycle in the journal");
  return c;
}

Result<std::map<std::uint64_t, std::vector<CellPartTruth>>> readTruthFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the truth file");
  std::map<std::uint64_t, std::vector<CellPartTruth>> out;
  int lineNo = 0;
  for (std::string line; std::getline(in, line);) {
    ++lineNo;
    if (line.empty()) continue;
    try {
      const auto j = nlohmann::json::parse(line);
      std::vector<CellPartTruth> parts;
      for (const auto& p : j.at("parts")) {
        CellPartTruth t;
        t.xMm = p.at("x_mm").get<double>();
        t.yMm = p.at("y_mm").get<double>();
        t.zMm = p.value("z_mm", 0.0);
        t.rzDeg = p.value("rz_deg", 0.0);
        t.label = p.value("label", 0);
        parts.push_back(t);
      }
      out[j.at("frame_id").get<std::uint64_t>()] = std::move(parts);
    } catch (const nlohmann::json::exception& e) {
      return fail(Status::BadArgument, fmt::format("{}:{}: not a truth line: {}", path, lineNo, e.what()));
    }
  }
  return out;
}

Result<std::map<std::uint32_t, JournalCycle>> readJournalFile(const std::string& path, int job) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the journal");
  std::map<std::uint32_t, JournalCycle> out;
  int lineNo = 0;
  for (std::string line; std::getline(in, line);) {
    ++lineNo;
    if (line.empty()) continue;
    try {
      const auto j = nlohmann::json::parse(line);
      if (job != 0 && j.value("job", 0) != job) continue;
      JournalCycle c;
      c.status = j.at("status").get<int>();
      c.frameId = j.value("frame_id", std::uint64_t{0});
      for (const auto& p : j.at("parts")) c.parts.push_back({p.at("x_mm").get<double>(), p.at("y_mm").get<double>(), p.value("label", 0)});
      out[j.at("cycle").get<std::uint32_t>()] = std::move(c);
    } catch (const nlohmann::json::exception& e) {
      return fail(Status::BadArgument, fmt::format("{}:{}: not a journal line: {}", path, lineNo, e.what()));
    }
  }
  return out;
}

}  // namespace vgr::sim
