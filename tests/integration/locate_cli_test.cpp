// The localization tools as users run them: `vgr sim render` -> `vgr teach` -> `vgr locate
// --json` and `vgr eval --json`, checked against the dataset's truth.csv; bad input gets a
// clear error and exit code 2. `vgr locate --overlay` and `vgr eval --overlays` draw the same
// picture of an image (vision/overlay.hpp, the one vgrd's page shows).
#include <unistd.h>

#include <array>
#include <cmath>
#include <map>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "vision/gray_image.hpp"
#include "tests/support/command.hpp"
#include "tests/support/temp_dir_test.hpp"

namespace {

namespace fs = std::filesystem;

using Run = vgr::test::CommandResult;

Run vgr(const std::string& args) { return vgr::test::runVgr(args); }

using vgr::test::lastLine;

class locate_cli : public vgr::test::TempDirTest {};

TEST_F(locate_cli, RenderTeachLocateEval) {
  const std::string data = (dir_ / "data").string(), job = (dir_ / "job").string();
  auto r = vgr("sim render --out " + data + " --count 6 --seed 4 --part flat --parts 2 --empty-ratio 0.3 --noise 3 "
               "--angle-range 180 --width 640 --height 512 --focal 1000");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto summary = nlohmann::json::parse(lastLine(r.out));
  ASSERT_GT(summary["empty_images"].get<int>(), 0);

  // The grasp point from template.yaml, as a user would copy it.
  std::ifstream ty(dir_ / "data" / "template.yaml");
  std::string line, grasp;
  while (std::getline(ty, line))
    if (line.rfind("# Teach a job on it:", 0) == 0) grasp = line.substr(line.find("--grasp ") + 8, line.find(" --regions") - line.find("--grasp ") - 8);
  ASSERT_FALSE(grasp.empty());
  r = vgr("teach --image " + data + "/template.png --grasp " + grasp + " --regions " + data + "/template.yaml --method hu --max-parts 4 --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  ASSERT_TRUE(fs::exists(dir_ / "job" / "job.yaml"));
  ASSERT_TRUE(fs::exists(dir_ / "job" / "template.png"));

  // vgr locate on every image: status and parts against truth.csv.
  std::map<std::string, std::vector<std::array<double, 3>>> truth;
  std::ifstream tc(dir_ / "data" / "truth.csv");
  std::getline(tc, line);
  while (std::getline(tc, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) f.push_back(c);
    auto& v = truth[f[0]];
    if (f.size() > 1 && !f[1].empty()) v.push_back({std::stod(f[1]), std::stod(f[2]), std::stod(f[3])});
  }
  ASSERT_EQ(truth.size(), 6u);
  for (const auto& [image, parts] : truth) {
    r = vgr("locate --job " + job + " --image " + data + "/" + image + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["status"].get<int>(), parts.empty() ? 1 : 0) << image;
    ASSERT_EQ(j["parts"].size(), parts.size()) << image << ": " << r.out;
    EXPECT_GE(j["time_ms"].get<double>(), 0);
    for (const auto& t : parts) {
      double best = 1e9;
      for (const auto& p : j["parts"]) best = std::min(best, std::hypot(p["x_px"].get<double>() - t[0], p["y_px"].get<double>() - t[1]));
      EXPECT_LT(best, 1.0) << image;  // hu on a flat part: 0.36 px max over 100 images (docs/localization.md)
    }
  }

  r = vgr("eval --job " + job + " --dataset " + data + " --plot " + (dir_ / "err.png").string() + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto e = nlohmann::json::parse(lastLine(r.out));
  EXPECT_DOUBLE_EQ(e["success_rate"].get<double>(), 1.0) << r.out;
  EXPECT_EQ(e["method"], "hu");
  EXPECT_TRUE(fs::exists(dir_ / "err.png"));
  // --method overrides the job's.
  r = vgr("eval --job " + job + " --dataset " + data + " --method moments --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(lastLine(r.out))["method"], "moments");
}

TEST_F(locate_cli, BadInputIsNamed) {
  auto r = vgr("teach --image /nonexistent.png --grasp 1,2 --out " + (dir_ / "j").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("/nonexistent.png: cannot read the image"), std::string::npos) << r.out;
  r = vgr("sim render --out " + (dir_ / "d").string() + " --count 1 --width 320 --height 256 --focal 500");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("teach --image " + (dir_ / "d" / "template.png").string() + " --grasp '1;2' --out " + (dir_ / "j").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("--grasp: expected X,Y in template px, got '1;2'"), std::string::npos) << r.out;
  r = vgr("teach --image " + (dir_ / "d" / "template.png").string() + " --grasp 1,2 --method sift --param ratio=7 --out " + (dir_ / "j").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("sift: parameter 'ratio'"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "j" / "job.yaml"));  // nothing written for a job that cannot be built
  r = vgr("locate --job " + (dir_ / "nojob").string() + " --image x.png --json");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("nojob/job.yaml: cannot open the job file"), std::string::npos) << r.out;
}

// Issue 18 item 7: `vgr locate` maps pixels as vgrd does. A job's `calibration` names a cell
// config; when that cell has calibration files, they map (daemon/cell_mapping.hpp), not its
// pinhole `model`, and the model may be left out. The example cell's files were calibrated on
// the simulated camera whose truth is the example's model, so a part's pose through the files
// agrees with the pose through the true model within the calibration's accuracy (0.03 mm
// measured here; bound 0.5 mm, vgrd's own bound in calib_vgrd_test), while a model knocked
// 100 mm off must change nothing.
TEST_F(locate_cli, MapsWithTheCellsCalibrationFilesAsVgrdDoes) {
  const std::string data = (dir_ / "data").string(), job = (dir_ / "job").string();
  auto r = vgr("sim render --out " + data + " --count 1 --seed 3 --part flat");  // the example cell's camera, 1280x1024
  ASSERT_EQ(r.exitCode, 0) << r.out;
  std::ifstream ty(dir_ / "data" / "template.yaml");
  std::string line, grasp;
  while (std::getline(ty, line))
    if (line.rfind("# Teach a job on it:", 0) == 0) grasp = line.substr(line.find("--grasp ") + 8, line.find(" --regions") - line.find("--grasp ") - 8);
  ASSERT_FALSE(grasp.empty());
  r = vgr("teach --image " + data + "/template.png --grasp " + grasp + " --method hu --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;

  // Three cells (the example's calibration files beside each): true model only; files + a
  // model 100 mm off; files and no model.
  const std::string example = vgr::config::embeddedSimCellYaml();
  const auto cut = [&](std::string yaml, const std::string& from, const std::string& to) {
    const auto a = yaml.find(from), b = yaml.find(to);
    EXPECT_NE(a, std::string::npos);
    EXPECT_NE(b, std::string::npos);
    return yaml.erase(a, b - a);
  };
  std::string offModel = example;
  offModel.replace(offModel.find("camera_x_mm: 400.0"), 18, "camera_x_mm: 500.0");
  std::map<std::string, std::string> cells = {{"model", cut(example, "calibration:\n", "modbus:\n")},
                                              {"files+off-model", offModel},
                                              {"files", cut(example, "model:\n", "calibration:\n")},
                                              {"off-model", cut(offModel, "calibration:\n", "modbus:\n")}};
  std::map<std::string, nlohmann::json> part;
  for (const auto& [name, yaml] : cells) {
    auto cfg = vgr::config::writeSimCell((dir_ / name).string(), yaml);
    ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
    vgr::config::JobFile j = *vgr::config::loadJob(job);
    j.calibration = *cfg;
    ASSERT_TRUE(vgr::config::writeJob(j).has_value());
    r = vgr("locate --job " + job + " --image " + data + "/img_00000.png --json");
    ASSERT_EQ(r.exitCode, 0) << name << ": " << r.out;
    const auto out = nlohmann::json::parse(r.out);
    ASSERT_EQ(out["parts"].size(), 1u) << name << ": " << r.out;
    part[name] = out["parts"][0];
    ASSERT_TRUE(part[name].contains("x_mm")) << name << ": " << r.out;
  }
  const auto dist = [&](const std::string& a, const std::string& b) {
    return std::hypot(part[a]["x_mm"].get<double>() - part[b]["x_mm"].get<double>(),
                      part[a]["y_mm"].get<double>() - part[b]["y_mm"].get<double>());
  };
  EXPECT_LT(dist("files+off-model", "model"), 0.5) << part["files+off-model"].dump() << " vs " << part["model"].dump();
  EXPECT_LT(dist("files", "model"), 0.5) << part["files"].dump();
  EXPECT_GT(dist("off-model", "model"), 50.0);  // the test can tell a model mapping from the files' one
}

// Issue 18 item 8 as the user meets it: an image the job cannot search (smaller than the
// template, or the job's ROI wholly outside it) is bad input: exit 2 and the reason, not
// exit 1 ("nothing found") or "expected a non-empty 8-bit gray image".
TEST_F(locate_cli, AnImageTheJobCannotSearchIsBadInput) {
  const std::string data = (dir_ / "data").string(), small = (dir_ / "small").string(), job = (dir_ / "job").string();
  auto r = vgr("sim render --out " + data + " --count 1 --seed 2 --part flat --width 640 --height 512 --focal 1000");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("sim render --out " + small + " --count 1 --seed 2 --part flat --width 100 --height 80 --focal 100");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  for (const char* method : {"hu", "shape"}) {
    r = vgr("teach --image " + data + "/template.png --grasp 50,50 --method " + std::string(method) + " --out " + job);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    r = vgr("locate --job " + job + " --image " + small + "/img_00000.png --json");
    EXPECT_EQ(r.exitCode, 2) << method << ": " << r.out;
    EXPECT_NE(r.out.find("smaller than the"), std::string::npos) << r.out;
    r = vgr("teach --image " + data + "/template.png --grasp 50,50 --roi 5000,5000,100,100 --method " + std::string(method) +
            " --out " + job);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    r = vgr("locate --job " + job + " --image " + data + "/img_00000.png --json");
    EXPECT_EQ(r.exitCode, 2) << method << ": " << r.out;
    EXPECT_NE(r.out.find("lies outside the 640x512 px image"), std::string::npos) << r.out;
    fs::remove_all(job);
  }
}

// Output paths are checked before the work starts (issue 18 item 6's rule, for the tools
// that write pictures): `vgr eval --plot` into a folder that does not exist used to fail only
// after every image was evaluated (the run lost, its JSON never printed). The data set has
// an unreadable image, which an evaluation names on stderr: no such line may appear.
TEST_F(locate_cli, OutputPathsAreCheckedBeforeTheWork) {
  const std::string data = (dir_ / "data").string(), job = (dir_ / "job").string();
  auto r = vgr("sim render --out " + data + " --count 2 --seed 5 --part flat --width 640 --height 512 --focal 1000");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("teach --image " + data + "/template.png --grasp 50,50 --method hu --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  std::ofstream(dir_ / "data" / "img_00001.png") << "not an image";
  const std::string plot = (dir_ / "no-such-folder" / "plot.png").string();
  r = vgr("eval --job " + job + " --dataset " + data + " --plot " + plot + " --json");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("--plot " + plot + ": the folder"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("left out"), std::string::npos) << "the data set was evaluated before the plot path was checked\n" << r.out;
  r = vgr("eval --job " + job + " --dataset " + data + " --plot " + (dir_ / "plot.txt").string() + " --json");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_EQ(r.out.find("left out"), std::string::npos) << r.out;

  const std::string overlay = (dir_ / "no-such-folder" / "o.png").string();
  r = vgr("locate --job " + job + " --image " + data + "/img_00000.png --overlay " + overlay + " --json");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("--overlay " + overlay + ": the folder"), std::string::npos) << r.out;
}

// Issue 18 item 2 as the user meets it: a Mono12 frame saved full-range (as vgr grab --save
// writes it) is located like the 8-bit image; the same frame saved LSB-aligned (0..4095, by
// another tool) used to be read as a nearly black image (gray 0..16) and located on those 17
// levels (exit 0 here; other images and methods: no part) with no word why.
TEST_F(locate_cli, SixteenBitFramesAreLocatedOrRefusedNeverReadBlack) {
  const std::string data = (dir_ / "data").string(), job = (dir_ / "job").string();
  auto r = vgr("sim render --out " + data + " --count 1 --seed 6 --part flat --width 640 --height 512 --focal 1000");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("teach --image " + data + "/template.png --grasp 50,50 --method hu --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const cv::Mat gray = cv::imread(data + "/img_00000.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(gray.empty());
  cv::Mat mono12;  // LSB-aligned 12-bit samples of the same picture
  gray.convertTo(mono12, CV_16UC1, 16.0);
  ASSERT_TRUE(cv::imwrite((dir_ / "full.png").string(), vgr::vision::toFullRange16(mono12, 12)));
  ASSERT_TRUE(cv::imwrite((dir_ / "lsb.png").string(), mono12));
  r = vgr("locate --job " + job + " --image " + (dir_ / "full.png").string() + " --json");
  EXPECT_EQ(r.exitCode, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["parts"].size(), 1u) << r.out;
  r = vgr("locate --job " + job + " --image " + (dir_ / "lsb.png").string() + " --json");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("LSB-aligned"), std::string::npos) << r.out;
}

TEST_F(locate_cli, LocateOverlayAndEvalOverlaysDrawTheSamePicture) {
  const std::string data = (dir_ / "data").string(), job = (dir_ / "job").string(), overlays = (dir_ / "overlays").string();
  auto r = vgr("sim render --out " + data + " --count 3 --seed 9 --part flat --parts 2 --noise 3 --width 640 --height 512 --focal 1000");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  std::ifstream ty(dir_ / "data" / "template.yaml");
  std::string line, grasp;
  while (std::getline(ty, line))
    if (line.rfind("# Teach a job on it:", 0) == 0) grasp = line.substr(line.find("--grasp ") + 8, line.find(" --regions") - line.find("--grasp ") - 8);
  ASSERT_FALSE(grasp.empty());
  r = vgr("teach --image " + data + "/template.png --grasp " + grasp + " --method hu --max-parts 4 --roi 20,20,600,470 --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("eval --job " + job + " --dataset " + data + " --overlays " + overlays + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  int pictures = 0;
  for (const auto& e : fs::directory_iterator(dir_ / "data")) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".png" || name == "template.png") continue;
    const std::string mine = (dir_ / ("locate-" + name)).string();
    r = vgr("locate --job " + job + " --image " + e.path().string() + " --json --overlay " + mine);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const auto j = nlohmann::json::parse(lastLine(r.out));
    const cv::Mat a = cv::imread(mine, cv::IMREAD_UNCHANGED), b = cv::imread((fs::path(overlays) / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(a.empty()) << mine;
    ASSERT_FALSE(b.empty()) << "vgr eval --overlays wrote no " << name;
    ASSERT_EQ(a.type(), CV_8UC3);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << name << ": the two tools drew different pictures";
    for (const auto& p : j["parts"]) {
      const cv::Vec3b px = a.at<cv::Vec3b>(static_cast<int>(std::lround(p["y_px"].get<double>())),
                                           static_cast<int>(std::lround(p["x_px"].get<double>())));
      EXPECT_TRUE(px[0] > 200 && px[1] < 60 && px[2] > 200) << name << ": no grasp disc at the part, BGR " << px;
    }
    const cv::Vec3b roi = a.at<cv::Vec3b>(200, 20);  // the ROI's left edge, yellow
    EXPECT_TRUE(roi[2] > 200 && roi[1] > 150 && roi[0] < 60) << "BGR " << roi;
    ++pictures;
  }
  EXPECT_EQ(pictures, 3);
  r = vgr("locate --job " + job + " --image " + data + "/template.png --overlay " + (dir_ / "no-extension").string());
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("--overlay"), std::string::npos) << r.out;
}

}  // namespace
