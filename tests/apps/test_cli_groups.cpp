// `kestrel --help` shows the user's commands and the lab apart; the lab's commands run under
// `kestrel lab`, and their former top-level names say where they went.
#include <gtest/gtest.h>

#include <string>

#include "cli_test.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::RunResult;

using CliGroups = kestrel::test::CliTest;

// The text between a heading line "NAME:" and the next blank line.
std::string section(const std::string& help, const std::string& heading) {
  const auto start = help.find("\n" + heading + ":\n");
  if (start == std::string::npos) return "";
  const auto body = start + heading.size() + 2;  // keeps the newline before the first entry
  const auto end = help.find("\n\n", body);
  return help.substr(body, end == std::string::npos ? std::string::npos : end - body);
}

TEST_F(CliGroups, HelpShowsTheUsersCommandsAndTheLabApart) {
  const RunResult r = run("--help");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string commands = section(r.out, "Commands");
  const std::string lab = section(r.out, "Lab");
  for (const char* name : {"odometry", "disparity", "fuse", "evaluate", "run", "capture", "fly",
                           "render", "pattern"}) {
    EXPECT_NE(commands.find(std::string("\n  ") + name + " "), std::string::npos)
        << name << " is not among the commands:\n"
        << r.out;
  }
  EXPECT_NE(lab.find("\n  lab "), std::string::npos) << r.out;
  for (const char* moved : {"fuse-eval", "stereo-experiment"}) {
    EXPECT_EQ(r.out.find(moved), std::string::npos) << moved << " listed at the top:\n" << r.out;
  }
}

TEST_F(CliGroups, LabHelpListsTheExperiments) {
  const RunResult r = run("lab --help");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("fuse-eval"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stereo-experiment"), std::string::npos) << r.out;
}

TEST_F(CliGroups, FormerNamesOfLabCommandsSayWhereTheyWent) {
  for (const std::string name : {"fuse-eval", "stereo-experiment"}) {
    const RunResult r = run(name + " --out " + kestrel::test::quoted((dir_ / "x").string()));
    EXPECT_EQ(r.exit_code, 1) << name;
    EXPECT_NE(r.err.find("`kestrel lab " + name + "`"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "x")) << name << " wrote output";
  }
}

TEST_F(CliGroups, LabWithoutACommandIsAnError) {
  const RunResult r = run("lab");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("subcommand"), std::string::npos) << r.err;
}

}  // namespace
