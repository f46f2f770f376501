// The cell config with 3D jobs (issue 14, docs/3d.md "vgrd"): a job folder with `kind: 3d` is
// a 3D job; it needs a depth camera (pixel_format Coord3D_C16) and a 2D job needs a 2D one,
// each refused with one line naming the job and the camera; a depth camera's calibration is
// the hand-eye file alone. The committed example sim-cell-3d.yaml loads and is what the
// embedded copy says.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"
#include "tests/support/temp_dir_test.hpp"

namespace {

namespace fs = std::filesystem;

class cell_config_3d : public vgr::test::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    fs::create_directories(dir_ / "job3d");
    std::ofstream(dir_ / "job3d" / "job.yaml") << "version: 1\nkind: 3d\nname: housing\n";
    std::ofstream(dir_ / "job3d" / "model.ply") << "ply\n";  // the config checks it exists; vgrd reads it
    std::ofstream(dir_ / "handeye.yaml") << "%YAML:1.0\n";
  }
  // A cell with camera pixel format `format`, `calibration` (a YAML block or "") and `job`.
  vgr::Result<vgr::config::CellConfig> cell(const std::string& format, const std::string& calibration, const std::string& job) {
    const std::string yaml = "cell: {name: t}\n"
                             "camera: {name: cam9, driver: aravis, address: 127.0.0.1, pixel_format: " + format + "}\n"
                             "model: {fx: 800, fy: 800, cx: 319.5, cy: 239.5}\n" + calibration +
                             "jobs:\n" + job;
    const std::string file = path("cell.yaml");
    std::ofstream(file) << yaml;
    return vgr::config::loadCellConfig(file);
  }
};

TEST_F(cell_config_3d, a_3d_job_on_a_depth_camera_loads_as_a_depth_job) {
  auto c = cell("Coord3D_C16", "calibration: {handeye: handeye.yaml}\n", "  - {id: 4, folder: job3d}\n");
  ASSERT_TRUE(c) << c.error().message;
  ASSERT_EQ(c->jobs.size(), 1u);
  EXPECT_TRUE(c->jobs[0].depth);
  EXPECT_TRUE(c->camera.depth());
  EXPECT_EQ(c->jobs[0].folder, path("job3d"));
  EXPECT_EQ(c->calibration.handeye, path("handeye.yaml"));
  EXPECT_TRUE(c->calibration.intrinsics.empty());
}

TEST_F(cell_config_3d, a_3d_job_on_a_2d_camera_is_refused_naming_the_job_and_the_camera) {
  auto c = cell("Mono8", "", "  - {id: 4, folder: job3d}\n");
  ASSERT_FALSE(c);
  const std::string& m = c.error().message;
  EXPECT_NE(m.find("cell.yaml:5: key 'jobs[0].folder'"), std::string::npos) << m;
  EXPECT_NE(m.find("job 4 is a 3D job"), std::string::npos) << m;
  EXPECT_NE(m.find("camera 'cam9' is a 2D camera (pixel_format Mono8)"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << "one line: " << m;
}

TEST_F(cell_config_3d, a_2d_job_on_a_depth_camera_is_refused_naming_the_job_and_the_camera) {
  auto c = cell("Coord3D_C16", "", "  - {id: 2, method: moments}\n");
  ASSERT_FALSE(c);
  const std::string& m = c.error().message;
  EXPECT_NE(m.find("key 'jobs[0]'"), std::string::npos) << m;
  EXPECT_NE(m.find("job 2 is a 2D job (method moments)"), std::string::npos) << m;
  EXPECT_NE(m.find("camera 'cam9' is a depth camera"), std::string::npos) << m;
}

TEST_F(cell_config_3d, a_depth_camera_takes_the_hand_eye_alone) {
  auto c = cell("Coord3D_C16", "calibration: {intrinsics: i.yaml, handeye: handeye.yaml, plane: p.yaml}\n",
                "  - {id: 4, folder: job3d}\n");
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("key 'calibration.intrinsics': not for a depth camera"), std::string::npos)
      << c.error().message;
  auto none = cell("Coord3D_C16", "calibration: {}\n", "  - {id: 4, folder: job3d}\n");
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().message.find("handeye"), std::string::npos) << none.error().message;
}

TEST_F(cell_config_3d, keys_of_2d_jobs_are_refused_on_a_3d_job) {
  auto c = cell("Coord3D_C16", "", "  - {id: 4, folder: job3d, angle_offset_deg: 90}\n");
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("key 'jobs[0].angle_offset_deg': not for a 3D job"), std::string::npos)
      << c.error().message;
}

TEST_F(cell_config_3d, a_robot_in_offset_mode_is_refused_on_a_3d_job) {
  const std::string yaml = "cell: {name: t}\ncamera: {name: cam9, address: 127.0.0.1, pixel_format: Coord3D_C16}\n"
                           "model: {fx: 800, fy: 800, cx: 319.5, cy: 239.5}\n"
                           "robots:\n  - {name: r, dialect: ur, port: 50010, deliver: offset}\n"
                           "jobs:\n  - {id: 4, folder: job3d}\n";
  std::ofstream(path("cell.yaml")) << yaml;
  auto c = vgr::config::loadCellConfig(path("cell.yaml"));
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("a 3D job has no taught reference"), std::string::npos) << c.error().message;
}

TEST(cell_config_3d_example, the_example_3d_cell_loads_and_matches_the_embedded_copy) {
  const std::string file = std::string(VGR_SOURCE_DIR) + "/config/examples/sim-cell-3d.yaml";
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, vgr::config::embeddedSimCell3dYaml());
  auto c = vgr::config::loadCellConfig(file);
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_TRUE(c->camera.depth());
  ASSERT_EQ(c->jobs.size(), 1u);
  EXPECT_TRUE(c->jobs[0].depth);
  EXPECT_EQ(c->robots.size(), 3u);
}

}  // namespace
