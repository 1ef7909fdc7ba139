// Test support for the ROS node (C++17): child processes that are always killed (SIGINT, then
// SIGKILL after a grace period, and PR_SET_PDEATHSIG should the test itself die), a rosmaster on
// loopback on a free port, one ros::init per test process, and polling with deadlines.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace kestrel::test {

/// Polls `done` every 10 ms until it holds or `timeout_s` has passed; returns whether it held.
inline bool wait_until(const std::function<bool()>& done, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A child process (fork + execve) with its stdout and stderr in `log`. The destructor stops it.
class ChildProcess {
 public:
  ChildProcess(const std::vector<std::string>& argv,
               const std::map<std::string, std::string>& env_overrides,
               const std::filesystem::path& log)
      : log_(log) {
    // Everything the child needs is built before fork(): after it only async-signal-safe calls.
    std::map<std::string, std::string> env;
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string entry(*e);
      const auto eq = entry.find('=');
      if (eq != std::string::npos) env[entry.substr(0, eq)] = entry.substr(eq + 1);
    }
    for (const auto& [k, v] : env_overrides) env[k] = v;
    std::vector<std::string> env_strings;
    for (const auto& [k, v] : env) env_strings.push_back(k + "=" + v);
    std::vector<char*> envp, args;
    for (auto& s : env_strings) envp.push_back(s.data());
    envp.push_back(nullptr);
    std::vector<std::string> argv_copy = argv;
    for (auto& s : argv_copy) args.push_back(s.data());
    args.push_back(nullptr);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the test
      if (::getppid() != parent) ::_exit(126);
      if (fd >= 0) {
        ::dup2(fd, STDOUT_FILENO);
        ::dup2(fd, STDERR_FILENO);
      }
      ::execve(args[0], args.data(), envp.data());
      ::_exit(127);
    }
    if (fd >= 0) ::close(fd);
  }
  ~ChildProcess() { stop(); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] std::string log() const { return read_text(log_); }

  /// Still running (not reaped)?
  bool running() {
    if (pid_ <= 0 || exited_) return false;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) record(status);
    return !exited_;
  }

  /// Waits up to timeout_s for the process to exit by itself; kills it if it does not.
  /// Returns its exit code, 128 + signal if a signal ended it, or -1 if it had to be killed.
  int wait_exit(double timeout_s) {
    if (!wait_until([this] { return !running(); }, timeout_s)) {
      kill_now();
      return -1;
    }
    return exit_code_;
  }

  /// SIGINT (as Ctrl-C), then SIGKILL if it has not exited after `grace_s`. Returns as
  /// wait_exit (-1: it had to be killed).
  int stop(double grace_s = 10.0) {
    if (pid_ <= 0) return -1;
    if (!running()) return exit_code_;
    ::kill(pid_, SIGINT);
    return wait_exit(grace_s);
  }

 private:
  void record(int status) {
    exited_ = true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  void kill_now() {
    if (pid_ <= 0 || exited_) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    exited_ = true;
    exit_code_ = -1;
  }

  std::filesystem::path log_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int exit_code_ = -1;
};

/// A TCP port on 127.0.0.1 that was free a moment ago (bind to port 0).
inline int free_loopback_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  int port = 0;
  if (::bind(s, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0) {
    socklen_t len = sizeof(addr);
    if (::getsockname(s, reinterpret_cast<sockaddr*>(&addr), &len) == 0)
      port = ntohs(addr.sin_port);
  }
  ::close(s);
  return port;
}

/// The environment every ROS process of a test gets: the loopback master, loopback addresses,
/// and a ROS_HOME of its own (logs).
inline std::map<std::string, std::string> ros_child_env(const std::string& master_uri,
                                                        const std::filesystem::path& ros_home) {
  return {{"ROS_MASTER_URI", master_uri},
          {"ROS_IP", "127.0.0.1"},
          {"ROS_HOSTNAME", "127.0.0.1"},
          {"ROS_HOME", ros_home.string()},
          {"ROSCONSOLE_STDOUT_LINE_BUFFERED", "1"}};
}

/// One rosmaster and one ros::init per test process, started on first use, stopped by the
/// global environment's TearDown (and by PR_SET_PDEATHSIG if the test process dies).
class RosTestEnvironment {
 public:
  static RosTestEnvironment& instance() {
    static RosTestEnvironment env;
    return env;
  }
  /// Empty when ready; else why not (the tests skip or fail with it).
  const std::string& start() {
    if (started_) return error_;
    started_ = true;
    if (std::string(KESTREL_ROSMASTER).empty() || !std::filesystem::exists(KESTREL_ROSMASTER)) {
      error_ = "rosmaster not found (python3-rosmaster, scripts/setup.sh)";
      return error_;
    }
    dir_ =
        std::filesystem::temp_directory_path() / ("kestrel_ros_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    for (int attempt = 0; attempt < 3 && !master_; ++attempt) {
      const int port = free_loopback_port();
      uri_ = "http://127.0.0.1:" + std::to_string(port);
      auto master = std::make_unique<ChildProcess>(
          std::vector<std::string>{KESTREL_ROSMASTER, "--core", "-p", std::to_string(port)},
          ros_child_env(uri_, dir_), dir_ / "rosmaster.log");
      if (!init_done_) {
        ::setenv("ROS_MASTER_URI", uri_.c_str(), 1);
        ::setenv("ROS_IP", "127.0.0.1", 1);
        ::setenv("ROS_HOSTNAME", "127.0.0.1", 1);
        ::setenv("ROS_HOME", dir_.c_str(), 1);
        int argc = 1;
        char name[] = "kestrel_ros_test";
        char* argv[] = {name, nullptr};
        ::ros::init(argc, argv, "kestrel_ros_test",
                    ::ros::init_options::AnonymousName | ::ros::init_options::NoSigintHandler);
        init_done_ = true;
      } else {
        // ros::init reads the URI once; a retry must use the same one, so only the first
        // attempt can change it. (A second attempt is for a master that died at start.)
        uri_ = ::ros::master::getURI();
      }
      if (wait_until([&] { return ::ros::master::check() || !master->running(); }, 20.0) &&
          master->running()) {
        master_ = std::move(master);
      } else {
        error_ = "rosmaster did not come up at " + uri_ + ": " + master->log();
        master->stop(2.0);
        if (attempt > 0) return error_;
      }
    }
    if (!master_) return error_;
    error_.clear();
    spinner_ = std::make_unique<::ros::AsyncSpinner>(2);
    spinner_->start();
    return error_;
  }
  void shutdown() {
    if (spinner_) spinner_->stop();
    spinner_.reset();
    if (init_done_) ::ros::shutdown();
    if (master_) master_->stop(5.0);
    master_.reset();
    // The node and master logs are kept for a failed run only.
    if (!dir_.empty() && ::testing::UnitTest::GetInstance()->Passed()) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
  }
  [[nodiscard]] const std::string& master_uri() const { return uri_; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }

 private:
  bool started_ = false, init_done_ = false;
  std::string error_;
  std::string uri_;
  std::filesystem::path dir_;
  std::unique_ptr<ChildProcess> master_;
  std::unique_ptr<::ros::AsyncSpinner> spinner_;
};

class RosTestTeardown : public ::testing::Environment {
 public:
  void TearDown() override { RosTestEnvironment::instance().shutdown(); }
};

}  // namespace kestrel::test

/// Starts (once) the master and ros::init. Skips the test when rosmaster is not installed;
/// fails it with the reason when the master does not come up.
#define KESTREL_REQUIRE_ROS_MASTER()                               \
  do {                                                             \
    const std::string kestrel_ros_error_ =                         \
        ::kestrel::test::RosTestEnvironment::instance().start();   \
    if (kestrel_ros_error_.rfind("rosmaster not found", 0) == 0) { \
      GTEST_SKIP() << kestrel_ros_error_;                          \
    }                                                              \
    ASSERT_TRUE(kestrel_ros_error_.empty()) << kestrel_ros_error_; \
  } while (0)
