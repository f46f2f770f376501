#include "sim/robot/robot_program.hpp"

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <fmt/core.h>

namespace vgr::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<double> numbers(const std::string& list) {
  std::vector<double> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
  return out;
}

Pose quatPose(const std::vector<double>& t, const std::vector<double>& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return Pose{t[0], t[1], t[2], q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

// URScript p[x, y, z, rx, ry, rz]: metres and a rotation vector (radians) -> mm + quaternion.
Pose urPose(double x, double y, double z, double rx, double ry, double rz) {
  const double a = std::sqrt(rx * rx + ry * ry + rz * rz);
  const double k = a > 1e-15 ? std::sin(a / 2) / a : 0.5;
  return Pose{x * 1000, y * 1000, z * 1000, std::cos(a / 2), rx * k, ry * k, rz * k};
}

double f32(double v) { return static_cast<double>(static_cast<float>(v)); }

bool near(const Pose& a, const Pose& b) {
  const double dq = std::abs(a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz);
  return std::abs(a.x - b.x) < 0.01 && std::abs(a.y - b.y) < 0.01 && std::abs(a.z - b.z) < 0.01 && dq > 1 - 1e-8;
}

std::string poseText(const Pose& p) {
  const auto e = toEulerZyxDeg(p);
  return fmt::format("({:.3f}, {:.3f}, {:.3f}) mm, rz {:.3f} ry {:.3f} rx {:.3f} deg", p.x, p.y, p.z, e.rz, e.ry, e.rx);
}

struct Needles {
  const std::string& text;
  const std::string& file;
  Result<void> require(std::initializer_list<const char*> needles) const {
    for (const char* n : needles)
      if (text.find(n) == std::string::npos)
        return fail(Status::BadArgument, fmt::format("{}: does not contain `{}` (the statement this player emulates)", file, n));
    return {};
  }
};

}  // namespace

Result<RobotProgram> loadRobotProgram(const std::vector<std::string>& files, config::Dialect dialect,
                                      const config::CellConfig& cell, const std::string& robot) {
  const config::RobotConfig* ep = nullptr;
  for (const auto& r : cell.robots)
    if (r.name == robot) ep = &r;
  if (!ep) return fail(Status::BadArgument, fmt::format("{}: no robot named '{}'", cell.sourcePath, robot));
  if (ep->dialect != dialect)
    return fail(Status::BadArgument, fmt::format("robot '{}' speaks {}, not {}", robot, config::dialectName(ep->dialect),
                                                 config::dialectName(dialect)));
  if (ep->delivery != config::Delivery::Offset)
    return fail(Status::BadArgument,
                fmt::format("the program applies offsets: robot '{}' in {} must have `deliver: offset`", robot, cell.sourcePath));
  std::vector<std::string> texts;
  for (const auto& f : files) {
    texts.push_back(readFile(f));
    if (texts.back().empty()) return fail(Status::BadArgument, f + ": cannot read the program");
  }
  auto jobRef = [&](int job) -> Result<Pose> {
    const config::JobConfig* j = cell.findJob(job);
    if (!j) return fail(Status::BadArgument, fmt::format("the program works on job {}, which {} does not have", job, cell.sourcePath));
    if (!j->referenceGiven) return fail(Status::BadArgument, fmt::format("job {} has no taught reference", job));
    return poseFromXyzRz(j->reference.x, j->reference.y, j->reference.z, j->reference.rzDeg * kPi / 180);
  };

  RobotProgram prog;
  prog.dialect = dialect;
  std::smatch m;
  if (dialect == config::Dialect::Abb) {
    if (files.size() != 1) return fail(Status::BadArgument, "abb: one program file (VgrPick.mod)");
    const std::string& mod = texts[0];
    const Needles need{mod, files[0]};
    if (auto r = need.require({"disp := [[vals{3}, vals{4}, vals{5}], OrientZYX(vals{6}, vals{7}, vals{8})];", "PDispSet disp;",
                               "MoveL pPick, v200, fine, tGripper \\WObj:="});
        !r)
      return std::unexpected(r.error());
    // Requests: every SocketSend before the loop is setup, the one inside is the poll.
    const std::regex send(R"re(SocketSend sock \\Str:="([^"]*)")re");
    std::vector<std::string> sends;
    for (auto it = std::sregex_iterator(mod.begin(), mod.end(), send); it != std::sregex_iterator(); ++it) sends.push_back((*it)[1]);
    if (sends.size() != 2 || sends[1] != "GET#" || !std::regex_match(sends[0], m, std::regex(R"(JOB,(\d+)#)")))
      return fail(Status::BadArgument, files[0] + ": expected SocketSend of \"JOB,<n>#\" then \"GET#\"");
    prog.setup = {sends[0]};
    prog.request = sends[1];
    prog.job = std::stoi(m[1]);
    const std::string src = mod;
    if (!std::regex_search(src, m, std::regex(R"(\\WObj:=(\w+);)")))
      return fail(Status::BadArgument, files[0] + ": no \\WObj:= in the moves");
    const std::string wobjName = m[1];
    const std::regex wobjRe("PERS wobjdata " + wobjName +
                            R"( := \[(?:TRUE|FALSE), (?:TRUE|FALSE), "[^"]*", \[\[([^\]]+)\],\[([^\]]+)\]\], \[\[([^\]]+)\],\[([^\]]+)\]\]\];)");
    if (!std::regex_search(src, m, wobjRe)) return fail(Status::BadArgument, files[0] + ": no wobjdata " + wobjName);
    const Pose wobj = compose(quatPose(numbers(m[1]), numbers(m[2])), quatPose(numbers(m[3]), numbers(m[4])));
    if (!std::regex_search(src, m, std::regex(R"(CONST robtarget pPick := \[\[([^\]]+)\],\[([^\]]+)\],)")))
      return fail(Status::BadArgument, files[0] + ": no robtarget pPick");
    const Pose pick = quatPose(numbers(m[1]), numbers(m[2]));
    if (wobjName != ep->frameName || !near(wobj, ep->baseFromUser))
      return fail(Status::BadArgument,
                  fmt::format("the program moves in work object {} at {}, but robot '{}' delivers in frame '{}' at {}", wobjName,
                              poseText(wobj), robot, ep->frameName, poseText(ep->baseFromUser)));
    auto ref = jobRef(prog.job);
    if (!ref) return std::unexpected(ref.error());
    prog.grip = compose(inverse(compose(inverse(wobj), *ref)), pick);
    prog.tcp = [wobj, pick](const std::array<double, 6>& v) {
      const Pose d = poseFromEulerZyxDeg(f32(v[0]), f32(v[1]), f32(v[2]), EulerZyxDeg{f32(v[3]), f32(v[4]), f32(v[5])});
      return compose(compose(wobj, d), pick);
    };
    prog.summary = fmt::format("RAPID {}: JOB,{} then GET; PDispSet in {} at {}; pPick {}", files[0], prog.job, wobjName,
                               poseText(wobj), poseText(pick));
  } else if (dialect == config::Dialect::Fanuc) {
    if (files.size() != 2) return fail(Status::BadArgument, "fanuc: two program files (vgr_bg.kl and VGR_PICK.ls)");
    const std::string& kl = texts[0];
    const std::string& ls = texts[1];
    if (auto r = Needles{kl, files[0]}.require({"WRITE sock('GET,', JOB_NO::1, CR)", "offset.x = x; offset.y = y; offset.z = z",
                                                "offset.w = w; offset.p = p; offset.r = r",
                                                "SET_POS_REG(PR_OFFSET, offset, stat)", "PR_OFFSET = 10"});
        !r)
      return std::unexpected(r.error());
    if (auto r = Needles{ls, files[1]}.require({"UFRAME_NUM=1 ;", "L P[2:pick] 200mm/sec FINE Offset,PR[10:vgr offset] ;"}); !r)
      return std::unexpected(r.error());
    if (!std::regex_search(kl, m, std::regex(R"(JOB_NO = (\d+))")))
      return fail(Status::BadArgument, files[0] + ": no JOB_NO constant");
    prog.job = std::stoi(m[1]);
    prog.request = "GET," + std::to_string(prog.job) + "\r";  // WRITE sock('GET,', JOB_NO::1, CR)
    const std::regex p2(R"(P\[2:"pick"\]\{\s*GP1:\s*UF : 1, UT : 1,[^\n]*\n\s*X =\s*([-0-9.]+)\s*mm,\s*Y =\s*([-0-9.]+)\s*mm,\s*Z =\s*([-0-9.]+)\s*mm,\s*W =\s*([-0-9.]+)\s*deg,\s*P =\s*([-0-9.]+)\s*deg,\s*R =\s*([-0-9.]+)\s*deg)");
    if (!std::regex_search(ls, m, p2)) return fail(Status::BadArgument, files[1] + ": no P[2:\"pick\"] in UF 1 in /POS");
    const Pose pick = poseFromEulerZyxDeg(std::stod(m[1]), std::stod(m[2]), std::stod(m[3]), EulerZyxDeg{std::stod(m[6]), std::stod(m[5]), std::stod(m[4])});
    // UFRAME[1] is controller data: the cell config's frame is what was taught there.
    const Pose uf = ep->baseFromUser;
    auto ref = jobRef(prog.job);
    if (!ref) return std::unexpected(ref.error());
    prog.grip = compose(inverse(compose(inverse(uf), *ref)), pick);
    prog.tcp = [uf, pick](const std::array<double, 6>& v) {
      // PR[10] = (x, y, z, w, p, r): R = Rz(r) Ry(p) Rx(w), applied as a frame in UFRAME 1.
      const Pose d = poseFromEulerZyxDeg(f32(v[0]), f32(v[1]), f32(v[2]), EulerZyxDeg{f32(v[5]), f32(v[4]), f32(v[3])});
      return compose(compose(uf, d), pick);
    };
    prog.summary = fmt::format("KAREL {} + TP {}: GET,{}; Offset,PR[10] in UFRAME 1 = '{}' at {}; P[2] {}", files[0], files[1],
                               prog.job, ep->frameName, poseText(uf), poseText(pick));
  } else if (dialect == config::Dialect::Ur) {
    if (files.size() != 1) return fail(Status::BadArgument, "ur: one program file (vgr_offset.script)");
    const std::string& sc = texts[0];
    if (auto r = Needles{sc, files[0]}.require({"offset = p[r[3], r[4], r[5], r[6], r[7], r[8]]", "part = pose_trans(ref, offset)",
                                                "pick = pose_trans(part, grip)", "movel(pick,"});
        !r)
      return std::unexpected(r.error());
    if (!std::regex_search(sc, m, std::regex(R"re(socket_send_line\("GET,(\d+)")re")))
      return fail(Status::BadArgument, files[0] + ": no socket_send_line(\"GET,<n>\")");
    prog.job = std::stoi(m[1]);
    prog.request = "GET," + std::to_string(prog.job) + "\n";  // socket_send_line adds the newline
    auto pose = [&](const char* name) -> Result<Pose> {
      std::smatch pm;
      if (!std::regex_search(sc, pm, std::regex(std::string(name) + R"( = p\[([^\]]+)\])")))
        return fail(Status::BadArgument, fmt::format("{}: no `{} = p[...]`", files[0], name));
      const auto v = numbers(pm[1]);
      if (v.size() != 6) return fail(Status::BadArgument, fmt::format("{}: `{}` needs 6 numbers", files[0], name));
      return urPose(v[0], v[1], v[2], v[3], v[4], v[5]);
    };
    auto ref = pose("ref");
    auto grip = pose("grip");
    if (!ref) return std::unexpected(ref.error());
    if (!grip) return std::unexpected(grip.error());
    prog.grip = *grip;
    prog.tcp = [r = *ref, g = *grip](const std::array<double, 6>& v) {
      return compose(compose(r, urPose(v[0], v[1], v[2], v[3], v[4], v[5])), g);
    };
    prog.summary = fmt::format("URScript {}: GET,{}; pose_trans(ref, offset), ref {}, grip {}", files[0], prog.job,
                               poseText(*ref), poseText(*grip));
  } else {
    return fail(Status::BadArgument, "--program: abb, fanuc or ur");
  }
  return prog;
}

}  // namespace vgr::sim
