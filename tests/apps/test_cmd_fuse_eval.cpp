// `kestrel lab fuse-eval --plot-dir`: the time-offset runs as a figure and a CSV, written into a
// folder the command claims (never over the user's files), refused before any work where the
// plots could not be made.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "cli_test.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

using CmdFuseEval = kestrel::test::CliTest;

// Short simulated runs only (no EuRoC data needed: --skip-real; a --data folder is still named).
const std::string kQuick =
    "lab fuse-eval --skip-real --runs 1 --duration 4 --offset-flights 2 --time-offset-ms 0 15 ";

TEST_F(CmdFuseEval, PlotDirGetsTheFigureAndEveryRunsSeries) {
  const fs::path out = dir_ / "plots";
  const RunResult r =
      run(kQuick + "--data " + quoted(dir_.string()) + " --plot-dir " + quoted(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("oracle bound on t_d's 1-sigma at 10 s"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(out / "time_offset.png"));
  EXPECT_GT(fs::file_size(out / "time_offset.png"), 1000U);
  std::ifstream csv(out / "time_offset.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "# written by kestrel lab fuse-eval");
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "offset_ms,flight,t_s,estimate_ms,sigma_ms,oracle_sigma_ms");
  int rows = 0, flight2_at_15 = 0;
  while (std::getline(csv, line)) {
    ++rows;
    if (line.rfind("15,2,", 0) == 0) ++flight2_at_15;
  }
  // 2 offsets x 2 flights x ~4 s at 20 Hz.
  EXPECT_GT(rows, 4 * 70);
  EXPECT_GT(flight2_at_15, 70);
  // A re-run of the same command reuses its own folder.
  EXPECT_EQ(run(kQuick + "--data " + quoted(dir_.string()) + " --plot-dir " + quoted(out.string()))
                .exit_code,
            0);
}

TEST_F(CmdFuseEval, PlotDirHoldingOtherFilesIsRefusedBeforeTheWork) {
  const fs::path out = dir_ / "mine";
  fs::create_directories(out);
  std::ofstream(out / "notes.txt") << "the user's\n";
  const RunResult r =
      run(kQuick + "--data " + quoted(dir_.string()) + " --plot-dir " + quoted(out.string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("mine"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("Time offset"), std::string::npos) << "ran before refusing:\n" << r.out;
  EXPECT_FALSE(fs::exists(out / "time_offset.csv"));
}

TEST_F(CmdFuseEval, PlotDirWithoutTheSimulationIsAnError) {
  const RunResult r = run("lab fuse-eval --skip-sim --data " + quoted(dir_.string()) +
                          " --plot-dir " + quoted((dir_ / "p").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--skip-sim"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "p"));
}

}  // namespace
