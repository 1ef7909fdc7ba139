// Kestrel never overwrites a file or folder that another command (or the user) wrote.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

std::string contents(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(OutputGuard, NewFileAndSameCommandReRunAreAllowed) {
  const auto dir = test::fresh_temp_dir("io");
  const auto p = dir / "sub" / "traj.txt";
  EXPECT_NO_THROW(check_can_write_file(p, "odometry", false));
  EXPECT_TRUE(std::filesystem::is_directory(dir / "sub"));
  std::ofstream(p) << provenance_line("odometry") << "\n1 2 3\n";
  EXPECT_NO_THROW(check_can_write_file(p, "odometry", false));
}

TEST(OutputGuard, ForeignFileIsRefusedUnlessForced) {
  const auto dir = test::fresh_temp_dir("io");
  const auto user = dir / "notes.txt";
  std::ofstream(user) << "my notes\n";
  try {
    check_can_write_file(user, "odometry", false);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("notes.txt"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos);
  }
  const auto other = dir / "gt.txt";
  std::ofstream(other) << provenance_line("render") << "\n";
  try {
    check_can_write_file(other, "odometry", false);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("kestrel render"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_can_write_file(other, "odometry", true));
}

TEST(OutputGuard, Folders) {
  const auto dir = test::fresh_temp_dir("io");
  EXPECT_NO_THROW(claim_output_dir(dir / "a", "render", false));
  std::ofstream(dir / "a" / "x.png") << "x";
  EXPECT_NO_THROW(claim_output_dir(dir / "a", "render", false));  // re-run
  EXPECT_THROW(claim_output_dir(dir / "a", "evaluate", false), InputError);
  std::filesystem::create_directories(dir / "mine");
  std::ofstream(dir / "mine" / "photo.jpg") << "x";
  EXPECT_THROW(claim_output_dir(dir / "mine", "render", false), InputError);
  EXPECT_NO_THROW(claim_output_dir(dir / "mine", "render", true));
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(claim_output_dir(dir / "file", "render", true), InputError);
}

// Images carry no provenance line: any existing one is refused without --force, and the refusal
// leaves it as it was.
TEST(OutputGuard, ExistingImageIsRefusedUnlessForced) {
  const auto dir = test::fresh_temp_dir("io");
  const auto photo = dir / "photo.png";
  std::ofstream(photo) << "\x89PNG not really";
  try {
    check_can_write_binary(photo, false);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("photo.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_can_write_binary(photo, true));
  EXPECT_NO_THROW(check_can_write_binary(dir / "new" / "d.png", false));
  EXPECT_TRUE(std::filesystem::is_directory(dir / "new"));
  EXPECT_FALSE(std::filesystem::exists(dir / "new" / "d.png"));  // the probe leaves nothing
}

// An output that is an input is refused even with --force: by its path, through "..", through a
// hard link (std::filesystem::equivalent); so are two outputs that are one file and an output
// folder that holds an input.
TEST(OutputGuard, OutputThatIsAnInputIsRefusedEvenWithForce) {
  const auto dir = test::fresh_temp_dir("io");
  std::filesystem::create_directories(dir / "sub");
  const auto left = dir / "left.png";
  std::ofstream(left) << "left";
  std::filesystem::create_hard_link(left, dir / "link.png");
  for (const auto& out : {left, dir / "sub" / ".." / "left.png", dir / "link.png"}) {
    OutputGuard guard("disparity", true);
    guard.input("--left", left);
    try {
      guard.binary_file("--color", out);
      FAIL() << out;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("--color"), std::string::npos) << what;
      EXPECT_NE(what.find("--left"), std::string::npos) << what;
    }
  }
  {
    OutputGuard guard("disparity", true);
    guard.input("--left", left).binary_file("--out", dir / "d.pfm");
    EXPECT_THROW(guard.binary_file("--color", dir / "sub" / ".." / "d.pfm"), InputError);
    EXPECT_NO_THROW(guard.binary_file("--depth", dir / "depth.png"));
  }
  OutputGuard folders("render", true);
  folders.input("--camera", left);
  EXPECT_THROW(folders.folder("--out", dir), InputError);
  EXPECT_NO_THROW(folders.folder("--out", dir / "sub"));
  EXPECT_EQ(contents(left), "left");
}

// A path that cannot be written is found by the check, before any work.
TEST(OutputGuard, UnwritablePathIsFoundByTheCheck) {
  const auto dir = test::fresh_temp_dir("io");
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(check_can_write_file(dir / "file" / "traj.txt", "odometry", true), InputError);
  // procfs takes no new files, whoever runs the test (root included).
  if (std::filesystem::is_directory("/proc/self")) {
    try {
      check_can_write_file("/proc/self/kestrel_traj.txt", "odometry", true);
      FAIL();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("/proc/self/kestrel_traj.txt"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace kestrel::io
