// `vgr teach --name ...` as a user types it, with names YAML would misread if written
// unescaped: the job folder it writes loads (config::loadJob) with the name unchanged.
// Runs the built `vgr` (VGR_BIN_DIR) with an exact argv, no shell in between; no ports.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;

int run(std::vector<std::string> args, const fs::path& log) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return -1;
  int st = 0;
  if (::waitpid(pid, &st, 0) != pid) return -1;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

TEST(teach_job_name, NamesWithQuotesBackslashesAndYamlSyntaxLoadBack) {
  const fs::path dir = fs::temp_directory_path() / ("vgr-teach-name-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat templ(120, 160, CV_8UC1, cv::Scalar(20));
  templ(cv::Rect(40, 30, 80, 50)).setTo(230);
  ASSERT_TRUE(cv::imwrite((dir / "template.png").string(), templ));

  int n = 0;
  for (const std::string name : {"box \"A\" C:\\temp", "# not a comment: {x}", "  spaced  ", "two\nlines", "ünï ✓"}) {
    const fs::path job = dir / ("job" + std::to_string(n++));
    const int rc = run({std::string(VGR_BIN_DIR) + "/vgr", "teach", "--image", (dir / "template.png").string(), "--grasp",
                        "80,55", "--param", "threshold=128", "--name", name, "--out", job.string()},
                       dir / "teach.log");
    ASSERT_EQ(rc, 0) << name;
    auto loaded = vgr::config::loadJob(job.string());
    ASSERT_TRUE(loaded.has_value()) << name << ": " << loaded.error().message;
    EXPECT_EQ(loaded->name, name);
    EXPECT_EQ(loaded->taught.params.at("threshold"), "128");
  }
  fs::remove_all(dir);
}

}  // namespace
