// vgrd with a depth camera and 3D jobs (issue 14; docs/3d.md "vgrd"), against the depth
// camera emulator over real GVSP, with the example 3D cell (config/examples/sim-cell-3d.yaml,
// written with rendered scenes by tools/vgr/demo3d.hpp):
//  - The emulator reports Scan3dDistanceUnit 'Pixel': the driver refuses the camera at every
//    (re)connect with a line naming the feature; a robot's TRIG is answered -4 CAMERA_ERROR
//    within its deadline, again and again.
//  - A 2D job on a depth camera, and a 3D job on a 2D camera: refused by `vgrd --check`,
//    `vgr check` and vgrd's start (exit 2), with one line naming the job and the camera.
//    (Before this change the first started and answered -2 on every cycle.)
//  - A scene without a part answers 1 NO_PART_FOUND to the PLC and a robot, journalled.
//  - Eye-in-hand: the flange pose sent with TRIG moves the 3D result exactly as the robot moved.
//  - The operator page's picture of a 3D cycle: the depth frame in false colour (last test).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/depth_dataset.hpp"
#include "depth_cell.hpp"
#include "sim/depth_scene.hpp"
#include "tests/support/command.hpp"
#include "tests/support/handeye_file.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "tests/support/sim_cell.hpp"
#include "tools/vgr/demo3d.hpp"
#include "vision/depth_image.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

// "(status,cycle,...)" -> status.
int urStatus(const std::string& reply) {
  if (reply.size() < 3 || reply.front() != '(') return -99;
  return std::stoi(reply.substr(1, reply.find(',') - 1));
}

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class depth_vgrd : public vgr::test::DepthCell {};

TEST_F(depth_vgrd, a_camera_in_an_unknown_unit_is_refused_and_vgrd_answers_camera_error) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1));
  ASSERT_NO_FATAL_FAILURE(start3dCell("Pixel", false));
  // The robot port comes up while the camera is being refused (after the 3D job is built).
  std::unique_ptr<vgr::test::RawTcpClient> ur;
  for (int i = 0; i < 900 && !ur; ++i) {
    vgr::test::RawTcpClient::Options o;
    o.throwOnFailure = false;
    auto c = std::make_unique<vgr::test::RawTcpClient>(kUrPort, o);
    if (c->connected()) ur = std::move(c);
    else std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(ur) << log("vgrd.log");
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(ur->send("TRIG,1\n"));
    const auto reply = ur->readUntil(')', 30000ms);
    ASSERT_TRUE(reply) << log("vgrd.log");
    EXPECT_EQ(urStatus(*reply), -4) << *reply;
  }
  EXPECT_TRUE(vgrd_->running());
  // The camera worker logs why it refuses the camera when its connect attempt ends, which
  // may be after the two cycles above were answered: wait for the line (up to 10 s).
  std::string l = log("vgrd.log");
  for (int i = 0; i < 100 && l.find("Scan3dDistanceUnit is 'Pixel'") == std::string::npos; ++i) {
    std::this_thread::sleep_for(100ms);
    l = log("vgrd.log");
  }
  EXPECT_NE(l.find("Scan3dDistanceUnit is 'Pixel'"), std::string::npos) << l;
}

TEST_F(depth_vgrd, a_2d_job_on_a_depth_camera_is_refused_at_check_and_start) {
  ASSERT_NO_FATAL_FAILURE(prepareCell([](std::string yaml) { return yaml; }));
  // The 2D example with its camera made a depth camera (and no calibration: a depth camera
  // takes the hand-eye alone).
  std::string yaml = readText(configPath_);
  const auto at = yaml.find("pixel_format: Mono8");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 19, "pixel_format: Coord3D_C16");
  const auto cal = yaml.find("\ncalibration:\n"), modbus = yaml.find("\nmodbus:\n");
  ASSERT_TRUE(cal != std::string::npos && modbus != std::string::npos);
  yaml.erase(cal, modbus - cal);
  std::ofstream(configPath_) << yaml;
  const std::string line = "job 1 is a 2D job (method moments) and camera 'cam0' is a depth camera";
  const auto check = vgr::test::runCommand(bin("vgrd") + " --check --config " + configPath_ + " 2>&1");
  EXPECT_EQ(check.exitCode, 2) << check.out;
  EXPECT_NE(check.out.find(line), std::string::npos) << check.out;
  const auto vgrCheck = vgr::test::runVgr("check --config " + configPath_);
  EXPECT_EQ(vgrCheck.exitCode, 2) << vgrCheck.out;
  EXPECT_NE(vgrCheck.out.find(line), std::string::npos) << vgrCheck.out;
  const auto start = vgr::test::runCommand(bin("vgrd") + " --config " + configPath_ + " --journal " + journalPath() + " 2>&1",
                                           std::chrono::milliseconds(30000));
  EXPECT_EQ(start.exitCode, 2) << start.out;
  EXPECT_NE(start.out.find(line), std::string::npos) << start.out;
}

TEST_F(depth_vgrd, a_3d_job_on_a_2d_camera_is_refused_at_check_and_start) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1));
  std::string yaml = readText(configPath_);
  const auto at = yaml.find("pixel_format: Coord3D_C16");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 25, "pixel_format: Mono8");
  std::ofstream(configPath_) << yaml;
  const std::string line = "job 1 is a 3D job (kind: 3d) and camera 'depth0' is a 2D camera (pixel_format Mono8)";
  const auto vgrCheck = vgr::test::runVgr("check --config " + configPath_);
  EXPECT_EQ(vgrCheck.exitCode, 2) << vgrCheck.out;
  EXPECT_NE(vgrCheck.out.find(line), std::string::npos) << vgrCheck.out;
  const auto start = vgr::test::runCommand(bin("vgrd") + " --config " + configPath_ + " --journal " + journalPath() + " 2>&1",
                                           std::chrono::milliseconds(30000));
  EXPECT_EQ(start.exitCode, 2) << start.out;
  EXPECT_NE(start.out.find(line), std::string::npos) << start.out;
}

}  // namespace

namespace {

// Scenes without a part: 1 NO_PART_FOUND on the PLC (ERROR_CODE 1, a valid result, no
// part) and to a robot (no pose), journalled, vgrd serving on. (4 RETRY_NEW_VIEWPOINT takes
// the same path: the PLC side is modbus_map.RetryNewViewpointIsAResultWithoutAPartAndNotAnError;
// no rendered scene gives it deterministically with today's localizer, docs/demo.md "3D".)
TEST_F(depth_vgrd, a_scene_without_a_part_is_not_found_on_every_wire) {
  vgr::tools::Demo3dScenes scenes;
  scenes.emptyRatio = 1;
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(2, scenes));
  // An archive section (it keeps every failed cycle's frame on a 2D cell): a depth camera's
  // frames are not archived, and vgrd says so at start instead of archiving nothing silently.
  std::ofstream(configPath_, std::ios::app) << "\narchive:\n  quota_mb: 4\n";
  ASSERT_NO_FATAL_FAILURE(start3dCell("Millimeter", true));
  auto plc = vgr::test::runCommand(bin("vgr-sim-plc") + " --host 127.0.0.1 --port 1502 --cycles 2 --job 1 --timeout-ms 40000 --json",
                                   std::chrono::milliseconds(120000));
  ASSERT_EQ(plc.exitCode, 0) << plc.out << log("vgrd.log");
  std::istringstream lines(plc.out);
  int seen = 0;
  for (std::string line; std::getline(lines, line);) {
    const auto p = nlohmann::json::parse(line, nullptr, false);
    if (p.is_discarded() || !p.contains("n")) continue;
    ++seen;
    EXPECT_EQ(p["status"].get<int>(), 1) << line;
    EXPECT_EQ(p["num_found"].get<int>(), 0) << line;
    const auto j = journalEntry(p["result_id"].get<std::uint32_t>());
    ASSERT_FALSE(j.is_null()) << line;
    EXPECT_EQ(j["status"].get<int>(), 1) << line;
    EXPECT_TRUE(j["parts"].empty()) << j.dump();
    EXPECT_FALSE(j.contains("archive")) << j.dump();
  }
  EXPECT_EQ(seen, 2) << plc.out;
  EXPECT_NE(log("vgrd.log").find("its frames are not archived"), std::string::npos) << log("vgrd.log");
  // The robot gets the last result's status and no pose; the connection stays.
  vgr::test::RawTcpClient ur(kUrPort);
  ASSERT_TRUE(ur.send("GET,1\n"));
  const auto reply = ur.readUntil(')', 5000ms);
  ASSERT_TRUE(reply);
  EXPECT_EQ(urStatus(*reply), 1) << *reply;
  std::string rest = reply->substr(reply->find(',', reply->find(',') + 1) + 1);  // after status and cycle
  rest.pop_back();  // ')'
  std::istringstream values(rest);
  for (std::string v; std::getline(values, v, ',');) EXPECT_EQ(std::stod(v), 0.0) << *reply;
  EXPECT_TRUE(vgrd_->running());
}

}  // namespace

namespace {

// An eye-in-hand 3D cell (issue 14): the depth camera rides on the flange (handeye.yaml
// eye-in-hand, X = T_flange_cam), so each TRIG carries the flange pose of its snapshot. One
// depth image (the emulator serves the same scene in every frame) sent with two flange poses
// A and B: the results are A X T_cam_grasp and B X T_cam_grasp, so B A^-1 maps the first onto
// the second exactly (the locator is deterministic on one image). A TRIG without a pose: -2.
TEST_F(depth_vgrd, eye_in_hand_the_pose_sent_moves_the_result_exactly_as_the_robot_moved) {
  vgr::tools::Demo3dScenes one;
  // Scene 0 of seed 1 (the demo's): one the localizer finds today (docs/demo.md "3D").
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1, one, 1));
  const vgr::Pose flangeFromCam = vgr::poseFromEulerZyxDeg(20, -10, 100, vgr::EulerZyxDeg{30, 0, 0});
  ASSERT_TRUE(vgr::test::writeTruthHandEye((dir_ / "sim-calib-3d/handeye.yaml").string(),
                                           vgr::vision::calib::HandEyeConfig::EyeInHand, flangeFromCam));
  ASSERT_NO_FATAL_FAILURE(start3dCell("Millimeter", true));

  const vgr::Pose flangeA = vgr::poseFromEulerZyxDeg(400, 50, 900, vgr::EulerZyxDeg{0, 0, 180});
  const vgr::Pose flangeB = vgr::poseFromEulerZyxDeg(250, -120, 820, vgr::EulerZyxDeg{40, 8, 175});
  auto urPose = [](const vgr::Pose& f) {
    const vgr::Vec3 rv = vgr::toRotationVector(f);
    return fmt::format("p[{:.6f}, {:.6f}, {:.6f}, {:.9f}, {:.9f}, {:.9f}]", f.x / 1000, f.y / 1000, f.z / 1000, rv.x, rv.y, rv.z);
  };
  vgr::test::RawTcpClient ur(kUrPort);
  auto trig = [&](const std::string& pose) -> nlohmann::json {
    EXPECT_TRUE(ur.send("TRIG,1" + pose + "\n"));
    const auto reply = ur.readUntil(')', 40000ms);
    EXPECT_TRUE(reply);
    if (!reply) return nullptr;
    const int status = urStatus(*reply);
    const auto cycle = std::stoul(reply->substr(reply->find(',') + 1));
    auto j = journalEntry(static_cast<std::uint32_t>(cycle));
    EXPECT_FALSE(j.is_null()) << *reply;
    if (!j.is_null()) {
      EXPECT_EQ(j["status"].get<int>(), status) << *reply;
    }
    return j;
  };
  const auto a = trig("," + urPose(flangeA));
  const auto b = trig("," + urPose(flangeB));
  ASSERT_FALSE(a.is_null());
  ASSERT_FALSE(b.is_null());
  ASSERT_EQ(a["status"].get<int>(), 0) << a.dump() << log("vgrd.log");
  ASSERT_EQ(b["status"].get<int>(), 0) << b.dump() << log("vgrd.log");
  auto pose = [](const nlohmann::json& part) {
    return vgr::poseFromEulerZyxDeg(part["x_mm"].get<double>(), part["y_mm"].get<double>(), part["z_mm"].get<double>(),
                                    vgr::EulerZyxDeg{part["rz_deg"].get<double>(), part["ry_deg"].get<double>(),
                                                     part["rx_deg"].get<double>()});
  };
  const vgr::Pose ra = pose(a["parts"][0]), rb = pose(b["parts"][0]);
  const vgr::Pose expected = vgr::compose(vgr::compose(flangeB, vgr::inverse(flangeA)), ra);
  const double d = std::sqrt((expected.x - rb.x) * (expected.x - rb.x) + (expected.y - rb.y) * (expected.y - rb.y) +
                             (expected.z - rb.z) * (expected.z - rb.z));
  const vgr::Pose diff = vgr::compose(vgr::inverse(expected), rb);
  const double angleDeg = 2.0 * std::acos(std::min(1.0, std::abs(diff.qw))) * 180.0 / M_PI;
  // The journal rounds to 0.001 mm / 0.001 deg; B A^-1 carries that over ~500 mm.
  EXPECT_LT(d, 0.02) << a.dump() << "\n" << b.dump();
  EXPECT_LT(angleDeg, 0.005) << a.dump() << "\n" << b.dump();
  // The two results differ by what the robot moved (not the same pose twice).
  EXPECT_GT(std::abs(ra.x - rb.x) + std::abs(ra.y - rb.y), 50.0);
  // A trigger without its flange pose cannot be mapped: -2, vgrd serving on.
  const auto none = trig("");
  ASSERT_FALSE(none.is_null());
  EXPECT_EQ(none["status"].get<int>(), -2);
  EXPECT_TRUE(vgrd_->running());
}

}  // namespace

namespace {

// Eye-in-hand 3D, two snapshot poses of one scene (issue 14): the depth camera on the flange
// sees the same part from flange poses A and B (two renders of one scene, the camera moved by
// V = T_camA_camB; B = A X V X^-1). The replay camera serves them in order (frame 1 = A's
// image, frame 2 = B's), each TRIG carries its flange pose; both results are the part's true
// pose in the base frame, A X T_camA_grasp, within the cell's bounds (1 mm, 1 deg).
TEST_F(depth_vgrd, eye_in_hand_two_snapshot_poses_of_one_scene_give_the_same_part) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1, vgr::tools::Demo3dScenes{}, 1));
  const vgr::Pose flangeFromCam = vgr::poseFromEulerZyxDeg(20, -10, 100, vgr::EulerZyxDeg{30, 0, 0});
  ASSERT_TRUE(vgr::test::writeTruthHandEye((dir_ / "sim-calib-3d/handeye.yaml").string(),
                                           vgr::vision::calib::HandEyeConfig::EyeInHand, flangeFromCam));
  // Scene 0 of the demo's scenes (seed 1), from the camera as rendered and moved by V.
  const vgr::Pose camAFromCamB = vgr::poseFromEulerZyxDeg(30, -20, 10, vgr::EulerZyxDeg{6, 0, 3});
  vgr::sim::DepthSceneOptions o;
  const vgr::tools::Demo3dScenes choice;
  o.part = choice.part;
  o.clutter = choice.clutter;
  o.tiltMaxDeg = choice.tiltMaxDeg;
  o.cameraTiltMaxDeg = choice.cameraTiltMaxDeg;
  o.bin = choice.bin;
  o.seed = 1;
  fs::create_directories(dir_ / "views" / "images");
  fs::copy_file(dir_ / "scenes" / "camera.yaml", dir_ / "views" / "camera.yaml");
  std::vector<vgr::config::DepthTruthRow> rows;
  for (int i = 0; i < 2; ++i) {
    o.view = i == 0 ? vgr::Pose{} : camAFromCamB;
    auto scene = vgr::sim::renderDepthScene(o, 0);
    ASSERT_TRUE(scene) << scene.error().message;
    ASSERT_EQ(scene->parts.size(), 1u);
    const std::string name = fmt::format("images/{:04d}.png", i);
    ASSERT_TRUE(cv::imwrite((dir_ / "views" / name).string(), scene->depth));
    rows.push_back({name, true, scene->parts[0].pose, 0});
  }
  ASSERT_TRUE(vgr::config::writeDepthTruth((dir_ / "views" / "truth.csv").string(), rows));
  // The cell's camera: the replay camera serving the two views in order.
  std::string yaml = readText(configPath_);
  const auto a = yaml.find("camera:\n"), b = yaml.find("\n# A depth camera sends");
  ASSERT_TRUE(a != std::string::npos && b != std::string::npos);
  yaml.replace(a, b - a,
               "camera:\n  name: depth0\n  driver: replay\n  pixel_format: Coord3D_C16\n  replay: {folder: " +
                   (dir_ / "views").string() + ", loop: true}\n  trigger: {mode: software}\n");
  std::ofstream(configPath_) << yaml;
  notify_ = std::make_unique<vgr::test::NotifySocket>((dir_ / "notify.sock").string());
  auto p = vgr::test::spawnWithNotify({bin("vgrd"), "--config", configPath_, "--journal", journalPath()},
                                      (dir_ / "vgrd.log").string(), *notify_);
  ASSERT_TRUE(p.has_value());
  vgrd_ = std::make_unique<vgr::test::ChildProcess>(std::move(*p));
  ASSERT_TRUE(waitNotify("READY=1", std::chrono::milliseconds(90000))) << log("vgrd.log");

  const vgr::Pose flangeA = vgr::poseFromEulerZyxDeg(400, 50, 900, vgr::EulerZyxDeg{0, 0, 180});
  const vgr::Pose flangeB =
      vgr::compose(vgr::compose(vgr::compose(flangeA, flangeFromCam), camAFromCamB), vgr::inverse(flangeFromCam));
  const vgr::Pose truth = vgr::compose(vgr::compose(flangeA, flangeFromCam), rows[0].pose);  // grasp = model frame
  auto abbPose = [](const vgr::Pose& f) {  // RAPID ValToStr of a pose
    return fmt::format("[[{:.4f},{:.4f},{:.4f}],[{:.7f},{:.7f},{:.7f},{:.7f}]]", f.x, f.y, f.z, f.qw, f.qx, f.qy, f.qz);
  };
  vgr::test::RawTcpClient abb(kAbbPort);
  for (const auto& [flange, frame] : {std::pair{flangeA, 1}, std::pair{flangeB, 2}}) {
    ASSERT_TRUE(abb.send("TRIG,1," + abbPose(flange) + "#"));
    const auto reply = abb.readOnce(80, 40000ms);
    ASSERT_TRUE(reply) << log("vgrd.log");
    const auto cycle = std::stoul(reply->substr(reply->find(',') + 1));
    const auto j = journalEntry(static_cast<std::uint32_t>(cycle));
    ASSERT_FALSE(j.is_null()) << *reply;
    EXPECT_EQ(j["frame_id"].get<std::uint64_t>(), static_cast<std::uint64_t>(frame)) << j.dump();
    ASSERT_EQ(j["status"].get<int>(), 0) << j.dump() << log("vgrd.log");
    const auto& part = j["parts"][0];
    const vgr::Pose got = vgr::poseFromEulerZyxDeg(part["x_mm"].get<double>(), part["y_mm"].get<double>(),
                                                   part["z_mm"].get<double>(),
                                                   vgr::EulerZyxDeg{part["rz_deg"].get<double>(), part["ry_deg"].get<double>(),
                                                                    part["rx_deg"].get<double>()});
    const double d = std::sqrt((got.x - truth.x) * (got.x - truth.x) + (got.y - truth.y) * (got.y - truth.y) +
                               (got.z - truth.z) * (got.z - truth.z));
    const vgr::Pose diff = vgr::compose(vgr::inverse(truth), got);
    const double angleDeg = 2.0 * std::acos(std::min(1.0, std::abs(diff.qw))) * 180.0 / M_PI;
    std::printf("snapshot %d: %.3f mm, %.3f deg from the truth\n", frame, d, angleDeg);
    EXPECT_LE(d, 1.0) << "snapshot " << frame << ": " << j.dump();
    EXPECT_LE(angleDeg, 1.0) << "snapshot " << frame << ": " << j.dump();
  }
}

}  // namespace

namespace {

// The operator page's picture of a 3D cycle (docs/3d.md "The page's depth picture"), over
// real HTTP from vgrd on the example 3D cell: /api/live.jpg after a robot's TRIG is the
// depth frame the emulator served (scene 0 of seed 1, one the localizer finds), in false
// colour at the frame's size: black where the frame has no data and nowhere else; every
// other pixel's colour read back through the colour map (cv::COLORMAP_TURBO, the z range
// the reply states in X-Vgr-Depth-Mm) gives the served z, on the part around its grasp point
// too; the grasp point's magenta disc at the journal's u_px, v_px. The browser drives the
// same page on this cell in web_page_browser_test.
struct HttpReply {
  int status = 0;
  std::string head, body;
  std::string header(const std::string& name) const {
    const auto at = head.find("\r\n" + name + ": ");
    if (at == std::string::npos) return "";
    const auto from = at + name.size() + 4;
    return head.substr(from, head.find("\r\n", from) - from);
  }
};

HttpReply httpGet(int port, const std::string& target) {
  const std::string r = vgr::test::httpRequest(static_cast<std::uint16_t>(port), "GET", target, 5000ms);
  HttpReply out;
  const auto p = r.find("\r\n\r\n");
  out.head = r.substr(0, p);
  if (p != std::string::npos) out.body = r.substr(p + 4);
  if (r.size() > 12) out.status = std::stoi(r.substr(9, 3));
  return out;
}

TEST_F(depth_vgrd, the_page_shows_a_3d_cycle_as_its_depth_frame_in_false_colour_with_the_part) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1, vgr::tools::Demo3dScenes{}, 1));
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  std::ofstream(configPath_, std::ios::app) << "\nweb:\n  bind: 127.0.0.1\n  port: " << port << "\n";
  ASSERT_NO_FATAL_FAILURE(start3dCell("Millimeter", true));

  vgr::test::RawTcpClient ur(kUrPort);
  ASSERT_TRUE(ur.send("TRIG,1\n"));
  const auto reply = ur.readUntil(')', 40000ms);
  ASSERT_TRUE(reply) << log("vgrd.log");
  ASSERT_EQ(urStatus(*reply), 0) << *reply << log("vgrd.log");
  const auto cycle = static_cast<std::uint32_t>(std::stoul(reply->substr(reply->find(',') + 1)));
  const auto j = journalEntry(cycle);
  ASSERT_FALSE(j.is_null());
  ASSERT_EQ(j["parts"].size(), 1u) << j.dump();
  const double u = j["parts"][0]["u_px"].get<double>(), v = j["parts"][0]["v_px"].get<double>();

  const HttpReply live = httpGet(port, "/api/live.jpg");
  ASSERT_EQ(live.status, 200) << live.head << live.body;
  EXPECT_EQ(live.header("Content-Type"), "image/jpeg");
  EXPECT_EQ(live.header("X-Vgr-Cycle"), std::to_string(cycle));
  const std::string rangeText = live.header("X-Vgr-Depth-Mm");
  ASSERT_NE(rangeText.find(','), std::string::npos) << live.head;
  const double nearMm = std::stod(rangeText), farMm = std::stod(rangeText.substr(rangeText.find(',') + 1));
  ASSERT_GT(farMm, nearMm + 1) << rangeText;
  const std::vector<uchar> jpeg(live.body.begin(), live.body.end());
  const cv::Mat pic = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  ASSERT_FALSE(pic.empty()) << "the live picture does not decode as a JPEG";
  if (const char* shots = std::getenv("VGR_WEB_SHOTS")) {  // docs/img/commissioning-live-3d.jpg was saved so
    fs::create_directories(shots);
    std::ofstream(fs::path(shots) / "commissioning-live-3d.jpg", std::ios::binary) << live.body;
  }

  // The frame the emulator served (frame 1 = scene 0), in mm.
  auto cam = vgr::config::loadDepthCameraFile((dir_ / "scenes" / "camera.yaml").string());
  ASSERT_TRUE(cam) << cam.error().message;
  auto depth = vgr::vision::readDepthMm((dir_ / "scenes" / "images" / "0000.png").string(), cam->depthScaleMm, cam->width,
                                        cam->height);
  ASSERT_TRUE(depth) << depth.error().message;
  EXPECT_EQ(pic.cols, cam->width);  // the frame's size (640 px: below web.live_max_width, not scaled)
  EXPECT_EQ(pic.rows, cam->height);
  EXPECT_EQ(live.header("X-Vgr-Scale"), "1.000000");
  ASSERT_EQ(pic.size(), depth->size());

  // The stated range spans the served z (the 0.5th..99.5th percentile: within its extremes,
  // at least 98 % of the valid pixels inside).
  const cv::Mat valid = *depth > 0;
  double lo = 0, hi = 0;
  cv::minMaxLoc(*depth, &lo, &hi, nullptr, nullptr, valid);
  EXPECT_GE(nearMm, lo - 1);
  EXPECT_LE(farMm, hi + 1);
  const cv::Mat inside = valid & (*depth >= nearMm - 0.5) & (*depth <= farMm + 0.5);
  EXPECT_GE(cv::countNonZero(inside), 0.98 * cv::countNonZero(valid));

  // Every pixel read back: black where there is no data, else the map's entry nearest its
  // colour -> z. Away from depth edges (JPEG smears them), the caption banner (top 40 px)
  // and the colour bar (right 110 px). The map is the test's own (cv::applyColorMap).
  cv::Mat ramp(256, 1, CV_8UC1), table;
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(i) = static_cast<uchar>(i);
  cv::applyColorMap(ramp, table, cv::COLORMAP_TURBO);
  auto readZ = [&](const cv::Vec3b& c) {
    int best = 0, bestD = 1 << 30;
    for (int i = 0; i < 256; ++i) {
      const cv::Vec3b t = table.at<cv::Vec3b>(i);
      const int d = (c[0] - t[0]) * (c[0] - t[0]) + (c[1] - t[1]) * (c[1] - t[1]) + (c[2] - t[2]) * (c[2] - t[2]);
      if (d < bestD) bestD = d, best = i;
    }
    return farMm - best / 255.0 * (farMm - nearMm);
  };
  cv::Mat dz, gray;
  cv::morphologyEx(*depth, dz, cv::MORPH_GRADIENT, cv::Mat::ones(7, 7, CV_8UC1));  // max - min around each pixel
  const cv::Mat smooth = valid & (dz < 3.0);
  cv::cvtColor(pic, gray, cv::COLOR_BGR2GRAY);
  const double tolMm = 0.04 * (farMm - nearMm);  // ~10 of the map's 256 entries: JPEG's colour error
  int blackChecked = 0, blackOk = 0, zChecked = 0, zOk = 0, partChecked = 0, partOk = 0;
  double partZ = 0;
  for (int y = 40; y < pic.rows; y += 2)
    for (int x = 0; x < pic.cols - 110; x += 2) {
      const cv::Vec3b c = pic.at<cv::Vec3b>(y, x);
      if (!valid.at<uchar>(y, x)) {
        // The frame's pixels without data are single dropouts and the rims of depth edges
        // here: black, so darker than the pixels 2 px around (JPEG softens a lone black pixel).
        if (y < 42 || x < 2 || y >= pic.rows - 2) continue;
        const int around = (gray.at<uchar>(y - 2, x) + gray.at<uchar>(y + 2, x) + gray.at<uchar>(y, x - 2) +
                            gray.at<uchar>(y, x + 2)) / 4;
        ++blackChecked;
        blackOk += gray.at<uchar>(y, x) + 20 < around || gray.at<uchar>(y, x) < 20;
        continue;
      }
      if (!smooth.at<uchar>(y, x) || !inside.at<uchar>(y, x)) continue;
      const float z = depth->at<float>(y, x);
      const bool ok = std::abs(readZ(c) - z) <= tolMm;
      ++zChecked;
      zOk += ok;
      // The part around its grasp point: 12..30 px out (outside the disc; the axes and the
      // label cross a few of these pixels).
      const double r = std::hypot(x - u, y - v);
      if (r >= 12 && r <= 30) {
        ++partChecked;
        partOk += ok;
        partZ += z;
      }
    }
  std::printf("depth picture: range %.1f..%.1f mm (frame %.1f..%.1f); no data black %d/%d; z read back within %.1f mm "
              "%d/%d; around the part (mean z %.1f mm) %d/%d\n",
              nearMm, farMm, lo, hi, blackOk, blackChecked, tolMm, zOk, zChecked, partChecked ? partZ / partChecked : 0.0,
              partOk, partChecked);
  EXPECT_GT(blackChecked, 50) << "the served frame has pixels without data";
  EXPECT_GE(blackOk, 0.8 * blackChecked) << "no data is black";
  EXPECT_GT(zChecked, 20000) << "not blank: most of the frame is valid z";
  EXPECT_GE(zOk, 0.95 * zChecked) << "the colours say the served z";
  EXPECT_GT(partChecked, 100);
  EXPECT_GE(partOk, 0.8 * partChecked) << "the colour where the part is says the part's z";
  // The grasp point's magenta disc at the journal's u_px, v_px.
  const cv::Vec3b g = pic.at<cv::Vec3b>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u)));
  EXPECT_TRUE(g[0] > 180 && g[1] < 90 && g[2] > 180) << g;
  EXPECT_TRUE(vgrd_->running());
}

}  // namespace
