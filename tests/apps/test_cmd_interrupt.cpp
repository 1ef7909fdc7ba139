// Ctrl-C (SIGINT) and SIGTERM sent to a running `kestrel odometry`: it stops after the current
// frame, writes the trajectory of the frames done and a --frames log of whole rows, says so and
// exits with 128 + the signal.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "kestrel/io/trajectory_io.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kInterruptSequence =
    "euroc/V1_01_easy_part1";  // 60 stereo pairs, ~50 ms each

std::vector<std::string> rows_of_text(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// `kestrel args...` with stdout and stderr to files; the child's pid.
pid_t spawn_kestrel(const std::vector<std::string>& args, const fs::path& out,
                    const fs::path& err) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> all{KESTREL_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, KESTREL_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

// The child's exit status; -(signal) if a signal ended it (the handler did not run); -1000 if
// it had to be killed after `limit`.
int wait_for(pid_t pid, std::chrono::seconds limit) {
  const auto deadline = Clock::now() + limit;
  int status = 0;
  while (Clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1000;
}

class CmdInterrupt : public ::testing::TestWithParam<int> {};

TEST_P(CmdInterrupt, OdometryStopsAndWritesWhatWasDone) {
  KESTREL_REQUIRE_DATA(kInterruptSequence);
  ASSERT_TRUE(fs::exists(KESTREL_BINARY)) << KESTREL_BINARY << " not found";
  const int signal_number = GetParam();
  const fs::path dir = kestrel::test::fresh_temp_dir("cmd_interrupt");
  const fs::path csv = dir / "frames.csv";
  const pid_t pid = spawn_kestrel(
      {"odometry", "--stereo", (kestrel::test::shared_data_dir() / kInterruptSequence).string(),
       "--out", (dir / "t.txt").string(), "--frames", csv.string()},
      dir / "stdout.txt", dir / "stderr.txt");
  ASSERT_GT(pid, 0) << "posix_spawn failed";

  // Wait until a few frames are logged (the log is flushed row by row), then interrupt.
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  bool exited = false;
  while (Clock::now() < deadline && rows_of_text(kestrel::test::slurp(csv)).size() < 2 + 3) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_FALSE(exited) << "kestrel ended before it could be interrupted:\n"
                       << kestrel::test::slurp(dir / "stderr.txt");
  ASSERT_EQ(kill(pid, signal_number), 0);
  const int code = wait_for(pid, std::chrono::seconds(60));
  const std::string err = kestrel::test::slurp(dir / "stderr.txt");
  ASSERT_EQ(code, 128 + signal_number) << err;

  // It said so, and stopped early.
  EXPECT_NE(err.find("INTERRUPTED after "), std::string::npos) << err;
  EXPECT_NE(err.find(" of 60 frames"), std::string::npos) << err;
  const auto trajectory = kestrel::io::read_tum_trajectory(dir / "t.txt");
  EXPECT_GE(trajectory.size(), 3U);
  EXPECT_LT(trajectory.size(), 60U);

  // One whole row per frame in the trajectory, each with the header's number of fields.
  const auto rows = rows_of_text(kestrel::test::slurp(csv));
  ASSERT_GE(rows.size(), 2U);
  EXPECT_EQ(rows.size() - 2, trajectory.size());
  const auto columns = std::count(rows[1].begin(), rows[1].end(), ',');
  for (std::size_t i = 2; i < rows.size(); ++i) {
    EXPECT_EQ(std::count(rows[i].begin(), rows[i].end(), ','), columns) << rows[i];
    EXPECT_EQ(rows[i].rfind(std::to_string(i - 2) + ",", 0), 0U) << rows[i];
  }
  const std::string text = kestrel::test::slurp(csv);
  EXPECT_EQ(text.back(), '\n') << "the last row is cut";
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Signals, CmdInterrupt, ::testing::Values(SIGINT, SIGTERM),
                         [](const ::testing::TestParamInfo<int>& param_info) {
                           return param_info.param == SIGINT ? std::string("SIGINT")
                                                             : std::string("SIGTERM");
                         });

}  // namespace
