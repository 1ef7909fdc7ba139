// Kestrel never overwrites a file or folder that another command (or the user) wrote.
#include <gtest/gtest.h>

#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

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

}  // namespace
}  // namespace kestrel::io
