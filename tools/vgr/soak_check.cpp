#include "tools/vgr/soak_check.hpp"

#include "core/status.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <fmt/format.h>

namespace vgr::tools::soak {

namespace {

namespace fs = std::filesystem;

constexpr double kPoseTolMm = 0.01;
constexpr double kAngleTolDeg = 0.01;
constexpr double kEdge = 0.020;      // s: a result this close to a request's edge is ambiguous
constexpr std::size_t kProblemsPerKind = 5;

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

bool samePose(const JournalEntry& j, double x, double y, double rz) {
  return j.hasPart && std::abs(j.x - x) <= kPoseTolMm && std::abs(j.y - y) <= kPoseTolMm && angleDiff(j.rz, rz) <= kAngleTolDeg;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double r3(double v) { return std::round(v * 1000.0) / 1000.0; }

class Problems {
 public:
  void add(const std::string& kind, const std::string& what) {
    if (++count_[kind] <= kProblemsPerKind) list_.push_back(kind + ": " + what);
  }
  std::vector<std::string> list() const {
    std::vector<std::string> out = list_;
    for (const auto& [kind, n] : count_)
      if (n > kProblemsPerKind) out.push_back(fmt::format("{}: {} more", kind, n - kProblemsPerKind));
    return out;
  }

 private:
  std::map<std::string, std::size_t> count_;
  std::vector<std::string> list_;
};

}  // namespace

std::vector<JournalEntry> readJournals(const std::string& path, int& unparsable, int& files) {
  std::vector<JournalEntry> out;
  unparsable = 0;
  files = 0;
  std::vector<std::string> paths{path};
  for (int i = 1; fs::exists(path + "." + std::to_string(i)); ++i) paths.push_back(path + "." + std::to_string(i));
  for (const auto& p : paths) {
    std::ifstream in(p);
    if (!in) continue;
    ++files;
    for (std::string line; std::getline(in, line);) {
      if (line.empty()) continue;
      const auto j = nlohmann::json::parse(line, nullptr, false);
      if (!j.is_object() || !j.contains("cycle")) {
        ++unparsable;
        continue;
      }
      JournalEntry e;
      e.cycle = j.value("cycle", 0u);
      e.time = j.value("time", 0.0);
      e.publish = e.time + j.value("total_ms", 0.0) / 1000.0;
      e.trigger = j.value("trigger", std::string());
      e.job = j.value("job", 0);
      e.status = j.value("status", -99);
      if (j.contains("parts") && j["parts"].is_array() && !j["parts"].empty()) {
        const auto& part = j["parts"][0];
        e.hasPart = true;
        e.x = part.value("x_mm", 0.0);
        e.y = part.value("y_mm", 0.0);
        e.rz = part.value("rz_deg", 0.0);
      }
      out.push_back(e);
    }
  }
  std::sort(out.begin(), out.end(), [](const JournalEntry& a, const JournalEntry& b) { return a.publish < b.publish; });
  return out;
}

std::map<std::uint32_t, double> readLateHandOvers(const std::string& vgrdLogPath) {
  // "... cycle 59005: robots got the result 51.2 ms after it was published (...)"
  static const std::regex line(R"(cycle (\d+): robots got the result ([0-9.]+) ms after it was published)");
  std::map<std::uint32_t, double> out;
  std::ifstream in(vgrdLogPath);
  std::smatch m;
  for (std::string l; std::getline(in, l);)
    if (std::regex_search(l, m, line)) out[static_cast<std::uint32_t>(std::stoul(m[1].str()))] = std::stod(m[2].str());
  return out;
}

std::vector<std::string> readPauses(const std::string& vgrdLogPath) {
  std::vector<std::string> out;
  std::ifstream in(vgrdLogPath);
  for (std::string l; std::getline(in, l);)
    if (const auto at = l.find(" pause: "); at != std::string::npos) out.push_back(l.substr(at + 1));
  return out;
}

CheckResult check(const CheckInput& in) {
  Problems problems;
  const auto killedWithin = [&](double from, double to) {
    return std::any_of(in.kills.begin(), in.kills.end(), [&](double k) { return k >= from && k <= to; });
  };

  // ---- journal ------------------------------------------------------------------------
  std::map<std::uint32_t, const JournalEntry*> byCycle;
  int journalDuplicates = 0;
  for (const auto& e : in.journal) {
    if (!byCycle.emplace(e.cycle, &e).second) {
      ++journalDuplicates;
      problems.add("journal_duplicate", fmt::format("cycle {} has two journal lines", e.cycle));
    }
  }

  // Journal lines by the low 16 bits of their cycle id (what the PLC sees).
  std::multimap<std::uint16_t, const JournalEntry*> byLow16;
  for (const auto& e : in.journal) byLow16.emplace(static_cast<std::uint16_t>(e.cycle & 0xFFFFu), &e);

  // ---- PLC ----------------------------------------------------------------------------
  const double plcDeadlineMs = in.cycleDeadlineMs + 100.0 + in.slackMs;
  long long triggers = 0, ok = 0, lost = 0, interrupted = 0, duplicated = 0, wrong = 0, late = 0, lateTyped = 0,
            journalMissing = 0, journalLostToKill = 0, journalMismatch = 0, plcDrops = 0;
  std::map<int, long long> typed;
  std::vector<double> latencies;
  std::set<std::uint32_t> matchedCycles;
  std::map<int, std::vector<std::pair<std::uint16_t, int>>> acqByIncarnation;  // recent ACQ_IDs
  for (const auto& t : in.plc) {
    ++triggers;
    if (t.plcDropped) ++plcDrops;
    if (!t.acked || !t.answered) {
      if (t.interrupted) {
        ++interrupted;
      } else {
        ++lost;
        problems.add("lost", fmt::format("trigger {} (t={:.3f}): no {} (stopped at {})", t.n, t.t0,
                                         t.acked ? "RESULT_VALID" : "TRIGGER_ACK", t.stoppedAt));
      }
      continue;
    }
    latencies.push_back(t.latencyMs);
    if (t.refused) {
      ++typed[t.status];
      continue;
    }
    // Never the same ACQ_ID twice (within the last 1000 triggers of one vgrd: ids are 16 bits).
    auto& recent = acqByIncarnation[t.incarnation];
    for (auto it = recent.rbegin(); it != recent.rend() && it - recent.rbegin() < 1000; ++it) {
      if (it->first == t.acqId) {
        ++duplicated;
        problems.add("duplicated", fmt::format("trigger {} got ACQ_ID {} like trigger {}", t.n, t.acqId, it->second));
        break;
      }
    }
    recent.emplace_back(t.acqId, t.n);
    if (t.resultId != t.acqId) {
      ++wrong;
      problems.add("wrong_trigger", fmt::format("trigger {}: RESULT_ID {} but ACQ_ID {}", t.n, t.resultId, t.acqId));
      continue;
    }
    if (t.latencyMs > plcDeadlineMs) {
      if (t.status != 0) {
        ++lateTyped;
      } else {
        problems.add("late", fmt::format("trigger {}: OK after {:.1f} ms (deadline {:.0f} ms)", t.n, t.latencyMs, plcDeadlineMs));
      }
      ++late;
    }
    if (t.status == 0)
      ++ok;
    else
      ++typed[t.status];
    // Its journal line: cycle id with these low 16 bits, trigger modbus, trigger time near t0.
    const JournalEntry* line = nullptr;
    for (auto [it, end] = byLow16.equal_range(t.acqId); it != end; ++it) {
      if (it->second->trigger == "modbus" && std::abs(it->second->time - t.t0) < 2.0) {
        line = it->second;
        break;
      }
    }
    if (!line) {
      // The journal is written after the PLC and robots were served: a kill -9 right after
      // the answer loses the line (docs/journal.md).
      if (killedWithin(t.t0, t.t0 + t.latencyMs / 1000.0 + 1.0)) {
        ++journalLostToKill;
      } else {
        ++journalMissing;
        problems.add("journal_missing", fmt::format("trigger {} (cycle id ..{}): no journal line", t.n, t.acqId));
      }
      continue;
    }
    matchedCycles.insert(line->cycle);
    // The PLC's -5 may be the Modbus backstop's while the cycle itself ended otherwise later.
    const bool backstop = t.status == statusCode(Status::ProcessingTimeout);
    if (line->status != t.status && !backstop) {
      ++journalMismatch;
      problems.add("journal_mismatch",
                   fmt::format("cycle {}: PLC saw status {}, journal says {}", line->cycle, t.status, line->status));
    } else if (t.status == 0 && !samePose(*line, t.x, t.y, t.rz)) {
      ++journalMismatch;
      problems.add("journal_mismatch", fmt::format("cycle {}: PLC pose ({:.3f}, {:.3f}, {:.3f}) is not the journal's",
                                                   line->cycle, t.x, t.y, t.rz));
    }
  }
  long long journalUnmatched = 0, journalUnmatchedNearKill = 0;
  for (const auto& e : in.journal) {
    if (e.trigger != "modbus" || matchedCycles.count(e.cycle)) continue;
    if (killedWithin(e.time - 1.0, e.time + in.cycleDeadlineMs / 1000.0 + 2.0)) {
      ++journalUnmatchedNearKill;  // a trigger whose ACK the PLC never saw: vgrd died
    } else {
      ++journalUnmatched;
      problems.add("journal_unmatched", fmt::format("journal cycle {} (t={:.3f}) matches no PLC trigger", e.cycle, e.time));
    }
  }

  // ---- robots -------------------------------------------------------------------------
  nlohmann::ordered_json robotsJson = nlohmann::ordered_json::object();
  long long robotProblems = 0;
  std::vector<const JournalEntry*> jobCycles;  // by publish time
  for (const auto& e : in.journal) jobCycles.push_back(&e);
  // By vgrd's order (cycle id): the journal's publish time (trigger time to the ms +
  // total_ms) can put two results that came out together in either order.
  std::vector<const JournalEntry*> cyclesById = jobCycles;
  std::sort(cyclesById.begin(), cyclesById.end(),
            [](const JournalEntry* a, const JournalEntry* b) { return a->cycle < b->cycle; });
  for (const auto& robot : in.robots) {
    const auto& o = robot.options;
    const std::string name = o.name;
    long long replies = 0, rok = 0, rdup = 0, rwrong = 0, rlate = 0, rmalformed = 0, rnoReply = 0, rinterrupted = 0,
              rmissed = 0, rbadError = 0, dropped = 0, stalled = 0, malformedSent = 0, rnotJudgedLate = 0;
    std::set<long long> got;  // cycles the robot received (or threw away itself)
    const double lateS = (in.replyDeadlineMs + in.slackMs) / 1000.0;
    const bool strict = o.dialect == protocol::Dialect::Strict;
    for (const auto& r : robot.records) {
      if (r.kind == RequestKind::Dropped) {
        ++dropped;
        for (long long c : r.discarded) got.insert(c);
        continue;
      }
      if (r.kind == RequestKind::Stalled) ++stalled;
      if (r.kind == RequestKind::Malformed) ++malformedSent;
      if (!r.answered) {
        if (killedWithin(r.sent - 0.5, r.sent + o.replyTimeoutMs / 1000.0 + 0.5)) {
          ++rinterrupted;
        } else {
          ++rnoReply;
          problems.add("robot_no_reply", fmt::format("{}: request at {:.3f}: {}", name, r.sent, r.error));
        }
        continue;
      }
      ++replies;
      if (!r.valid) {
        ++rmalformed;
        problems.add("robot_malformed_reply", fmt::format("{}: {}", name, r.error));
        continue;
      }
      if (r.kind == RequestKind::Normal && !strict && r.replied - r.sent > lateS &&
          !killedWithin(r.sent - 0.5, r.replied + 0.5)) {
        ++rlate;
        problems.add("robot_late", fmt::format("{}: reply after {:.0f} ms", name, (r.replied - r.sent) * 1000.0));
      }
      if (r.kind == RequestKind::Malformed) {
        if (r.status != r.expectedStatus) {
          ++rbadError;
          problems.add("robot_bad_error", fmt::format("{}: {}", name, r.error));
        }
        continue;
      }
      if (strict) {
        // Which cycle: the latest OK cycle published before the push with this pose.
        const JournalEntry* match = nullptr;
        auto upto = std::upper_bound(jobCycles.begin(), jobCycles.end(), r.sent + kEdge,
                                     [](double t, const JournalEntry* e) { return t < e->publish; });
        for (int back = 0; upto != jobCycles.begin() && back < 200 && !match; ++back) {
          --upto;
          if ((*upto)->status == 0 && samePose(**upto, r.x, r.y, r.rz)) match = *upto;
        }
        if (!match) {
          ++rwrong;
          problems.add("robot_wrong", fmt::format("{}: pushed pose ({:.3f}, {:.3f}, {:.3f}) is no journal cycle's", name,
                                                  r.x, r.y, r.rz));
        } else if (!got.insert(match->cycle).second) {
          ++rdup;
          problems.add("robot_duplicated", fmt::format("{}: cycle {} pushed twice", name, match->cycle));
        } else {
          ++rok;
        }
        continue;
      }
      if (r.status == statusCode(Status::ResultNotReady) || r.status == statusCode(Status::NoNewTrigger)) continue;
      auto it = byCycle.find(static_cast<std::uint32_t>(r.cycle));
      if (it == byCycle.end()) {
        // A cycle whose line was lost with a kill -9 cannot be checked; otherwise wrong.
        if (!killedWithin(r.replied - 2.0, r.replied + 1.0)) {
          ++rwrong;
          problems.add("robot_wrong", fmt::format("{}: cycle {} is not in the journal", name, r.cycle));
        }
        continue;
      }
      const JournalEntry& e = *it->second;
      if (e.status != r.status || (r.status == 0 && !samePose(e, r.x, r.y, r.rz))) {
        ++rwrong;
        problems.add("robot_wrong", fmt::format("{}: cycle {} status {} pose ({:.3f}, {:.3f}, {:.3f}) differs from the journal",
                                                name, r.cycle, r.status, r.x, r.y, r.rz));
        continue;
      }
      if (!got.insert(r.cycle).second) {
        ++rdup;
        problems.add("robot_duplicated", fmt::format("{}: cycle {} delivered twice", name, r.cycle));
        continue;
      }
      if (r.status == 0) ++rok;
    }
    // Missed: a cycle the robot never got although a request of its was in vgrd's hands
    // before the next cycle came and was answered with a newer one, or timed out (2/3) while
    // the cycle came out. Judged by vgrd's own order (which cycle answered which request),
    // not by when the robot's thread read the reply: on a loaded machine that thread may run
    // late. A request's `sent` is taken after its send() returned, so it is never early.
    // Cycles around a drop of this robot (the part may be on its way back, 50 ms reset
    // probe) or a kill of vgrd are not judged. Request dialects only (strict is a push).
    if (!strict) {
      std::vector<double> drops;
      for (const auto& r : robot.records)
        if (r.kind == RequestKind::Dropped) drops.push_back(r.replied);
      for (std::size_t i = 0; i < cyclesById.size(); ++i) {
        const JournalEntry& c = *cyclesById[i];
        if (c.job != o.job || got.count(c.cycle)) continue;
        if (killedWithin(c.publish - 1.0, c.publish + 0.5)) continue;  // went down with vgrd
        if (std::any_of(drops.begin(), drops.end(), [&](double d) { return c.publish > d - kEdge && c.publish < d + 0.2; }))
          continue;
        double next = 1e300;
        for (std::size_t k = i + 1; k < cyclesById.size(); ++k)
          if (cyclesById[k]->job == o.job) {
            next = cyclesById[k]->publish;
            break;
          }
        if (const auto lag = in.lateHandOverMs.find(c.cycle);
            lag != in.lateHandOverMs.end() && c.publish + lag->second / 1000.0 >= next - kEdge) {
          ++rnotJudgedLate;  // vgrd's I/O thread took this result up with the next one
          continue;
        }
        const RobotRequestRecord* eligible = nullptr;
        // A request sent more than its deadline (+ margin) before the cycle was answered before it.
        const double from = c.publish - in.replyDeadlineMs / 1000.0 - 1.0;
        const auto begin = std::lower_bound(robot.records.begin(), robot.records.end(), from,
                                            [](const RobotRequestRecord& r, double t) { return r.sent < t; });
        for (auto it = begin; it != robot.records.end(); ++it) {
          const RobotRequestRecord& r = *it;
          if (r.sent >= next - kEdge) break;  // records are in the robot's order
          if (r.kind != RequestKind::Normal || !r.answered || !r.valid) continue;
          const bool newer = r.status != statusCode(Status::ResultNotReady) &&
                             r.status != statusCode(Status::NoNewTrigger) && r.cycle > static_cast<long long>(c.cycle);
          const bool timedOutOverIt = (r.status == statusCode(Status::ResultNotReady) ||
                                       r.status == statusCode(Status::NoNewTrigger)) &&
                                      r.sent < c.publish - kEdge && c.publish < r.sent + in.replyDeadlineMs / 1000.0 - 0.5;
          if (newer || timedOutOverIt) {
            eligible = &r;
            break;
          }
        }
        if (eligible) {
          ++rmissed;
          problems.add("robot_missed", fmt::format("{}: cycle {} (published {:.3f}) never arrived; the request of {:.3f} got "
                                                   "cycle {} status {}",
                                                   name, c.cycle, c.publish, eligible->sent, eligible->cycle, eligible->status));
        }
      }
    }
    robotProblems += rdup + rwrong + rlate + rmalformed + rnoReply + rmissed + rbadError;
    robotsJson[name] = {{"dialect", protocol::dialectName(o.dialect)},
                        {"replies", replies},
                        {"ok", rok},
                        {"duplicated", rdup},
                        {"wrong", rwrong},
                        {"late", rlate},
                        {"malformed_replies", rmalformed},
                        {"no_reply", rnoReply},
                        {"missed", rmissed},
                        {"not_judged_late_hand_over", rnotJudgedLate},
                        {"interrupted", rinterrupted},
                        {"malformed_requests_sent", malformedSent},
                        {"malformed_requests_misanswered", rbadError},
                        {"dropped_mid_request", dropped},
                        {"stalled", stalled}};
  }

  nlohmann::ordered_json typedJson = nlohmann::ordered_json::object();
  for (const auto& [code, n] : typed) typedJson[std::to_string(code)] = n;
  CheckResult result;
  auto& s = result.summary;
  s["triggers"] = triggers;
  s["ok"] = ok;
  s["typed_errors"] = typedJson;
  s["lost"] = lost;
  s["duplicated"] = duplicated;
  s["wrong_trigger"] = wrong;
  s["late"] = late;
  s["late_typed"] = lateTyped;
  s["interrupted_by_kill"] = interrupted;
  s["plc_deadline_ms"] = plcDeadlineMs;
  s["max_latency_ms"] = r3(latencies.empty() ? 0.0 : *std::max_element(latencies.begin(), latencies.end()));
  s["p50_latency_ms"] = r3(percentile(latencies, 0.5));
  s["p99_latency_ms"] = r3(percentile(latencies, 0.99));
  s["plc_mid_handshake_drops"] = plcDrops;
  s["late_hand_overs"] = in.lateHandOverMs.size();
  s["pauses"] = in.pauses;
  s["journal"] = {{"lines", in.journal.size()},
                  {"duplicates", journalDuplicates},
                  {"missing", journalMissing},
                  {"lost_to_kill", journalLostToKill},
                  {"status_or_pose_mismatch", journalMismatch},
                  {"unmatched", journalUnmatched},
                  {"unmatched_near_kill", journalUnmatchedNearKill}};
  s["robots"] = robotsJson;
  const long long lateFailures = in.allowLateTyped ? late - lateTyped : late;
  result.pass = lost == 0 && duplicated == 0 && wrong == 0 && lateFailures == 0 && journalDuplicates == 0 &&
                journalMissing == 0 && journalMismatch == 0 && journalUnmatched == 0 && robotProblems == 0;
  result.problems = problems.list();
  return result;
}

}  // namespace vgr::tools::soak
