// `kestrel evaluate` end to end: runs the built binary (KESTREL_BINARY) and checks its last
// stdout line, its files and its exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_test.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;
using kestrel::test::slurp;

class CmdEvaluate : public kestrel::test::CliTest {
 protected:
  static std::string reference(const std::string& name) {
    return quoted(
        (kestrel::test::shared_data_dir() / "tum/reference_trajectories" / name).string());
  }
  static std::string reference_args() {
    return "evaluate --gt " + reference("freiburg1_xyz-groundtruth.txt") + " --est " +
           reference("freiburg1_xyz-rgbdslam.txt");
  }
};

TEST_F(CmdEvaluate, LastLineReproducesTheTumScriptsOnTheReferencePair) {
  KESTREL_REQUIRE_DATA("tum/reference_trajectories");
  const RunResult r = run(reference_args());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  double ate = 0, trans = 0, rot = 0;
  char tail = 0;
  ASSERT_EQ(
      std::sscanf(r.last_line().c_str(), "ate_rmse_m=%lf rpe_trans_m_s=%lf rpe_rot_deg_s=%lf%c",
                  &ate, &trans, &rot, &tail),
      3)
      << r.last_line();
  EXPECT_NEAR(ate, 0.013473, 0.0000005);
  EXPECT_NEAR(trans, 0.021217, 0.0000005);
  EXPECT_NEAR(rot, 0.934480, 0.0000005);
  EXPECT_NE(r.out.find("associated pairs: 786"), std::string::npos) << r.out;
  // The options are logged at start, on stderr.
  EXPECT_NE(r.err.find("max_diff_s=0.02 rpe_delta_s=1"), std::string::npos) << r.err;
}

TEST_F(CmdEvaluate, PlotWritesFiguresAndCsvsIntoAClaimedFolder) {
  KESTREL_REQUIRE_DATA("tum/reference_trajectories");
  const fs::path plots = dir_ / "plots";
  const RunResult r = run(reference_args() + " --plot " + quoted(plots.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* name :
       {"x.png", "y.png", "z.png", "roll.png", "pitch.png", "yaw.png", "top_view.png", "rpe.png",
        "axis_errors.csv", "rpe.csv", "est_aligned.txt"}) {
    EXPECT_TRUE(fs::exists(plots / name)) << name;
    EXPECT_NE(r.out.find("wrote " + (plots / name).string()), std::string::npos) << name;
  }
  EXPECT_EQ(r.last_line().rfind("ate_rmse_m=", 0), 0u) << r.last_line();
  // 786 pairs: provenance, header and one row each.
  std::ifstream csv(plots / "axis_errors.csv");
  std::size_t lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 788u);
  // A second run into its own folder is fine.
  EXPECT_EQ(run(reference_args() + " --plot " + quoted(plots.string())).exit_code, 0);
}

TEST_F(CmdEvaluate, RefusesAFolderOfSomeoneElse) {
  KESTREL_REQUIRE_DATA("tum/reference_trajectories");
  const fs::path plots = dir_ / "mine";
  fs::create_directories(plots);
  std::ofstream(plots / "thesis.tex") << "precious\n";
  const RunResult r = run(reference_args() + " --plot " + quoted(plots.string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("refusing"), std::string::npos) << r.err;
  EXPECT_EQ(run(reference_args() + " --plot " + quoted(plots.string()) + " --force").exit_code, 0);
  EXPECT_EQ(slurp(plots / "thesis.tex"), "precious\n");
}

TEST_F(CmdEvaluate, MissingFileIsExitOneNamingIt) {
  const fs::path missing = dir_ / "no_such_trajectory.txt";
  const RunResult r =
      run("evaluate --gt " + quoted(missing.string()) + " --est " + quoted(missing.string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(missing.string()), std::string::npos) << r.err;
}

TEST_F(CmdEvaluate, MalformedFileIsExitOneNamingFileAndLine) {
  const fs::path good = dir_ / "good.txt";
  const fs::path bad = dir_ / "bad.txt";
  std::ofstream(good) << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n";
  std::ofstream(bad) << "# estimate\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n";
  const RunResult r =
      run("evaluate --gt " + quoted(good.string()) + " --est " + quoted(bad.string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(bad.string() + ":3:"), std::string::npos) << r.err;
}

TEST_F(CmdEvaluate, DisjointTimesAreAClearErrorNotNan) {
  const fs::path gt = dir_ / "gt.txt";
  const fs::path est = dir_ / "est.csv";
  {
    std::ofstream g(gt), e(est);
    for (int k = 0; k < 50; ++k) {
      g << 100 + k * 0.1 << " " << k << " 0 0 0 0 0 1\n";
      e << (500 + k) * 100'000'000LL << "," << k << ",0,0,1,0,0,0\n";
    }
  }
  const RunResult r =
      run("evaluate --gt " + quoted(gt.string()) + " --est " + quoted(est.string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("pose pairs"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(est.string()), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
}

TEST_F(CmdEvaluate, OffsetShiftsTheEstimateBeforeTheAssociation) {
  // The estimate is the ground truth with its stamps 0.3 s late: matched as they are, every
  // pair compares poses 0.3 s apart on a 1 m/s line (ATE ~0.3 m before alignment, and the
  // RPE windows see no motion error either way); --offset -0.3 puts them back (ATE 0).
  const fs::path gt = dir_ / "gt.txt";
  const fs::path est = dir_ / "est.txt";
  {
    std::ofstream g(gt), e(est);
    for (int k = 0; k < 100; ++k) {
      const double t = 100.0 + k * 0.05, x = k * 0.05, y = 0.3 * std::sin(k * 0.1);
      g << t << " " << x << " " << y << " 0 0 0 0 1\n";
      e << t + 0.3 << " " << x << " " << y << " 0 0 0 0 1\n";
    }
  }
  const std::string args =
      "evaluate --gt " + quoted(gt.string()) + " --est " + quoted(est.string());
  double ate = 0, trans = 0, rot = 0;
  const RunResult plain = run(args);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  ASSERT_EQ(std::sscanf(plain.last_line().c_str(),
                        "ate_rmse_m=%lf rpe_trans_m_s=%lf rpe_rot_deg_s=%lf", &ate, &trans, &rot),
            3);
  EXPECT_GT(ate, 0.01);  // the curve does not align onto itself shifted along it
  const RunResult shifted = run(args + " --offset -0.3");
  ASSERT_EQ(shifted.exit_code, 0) << shifted.err;
  ASSERT_EQ(std::sscanf(shifted.last_line().c_str(),
                        "ate_rmse_m=%lf rpe_trans_m_s=%lf rpe_rot_deg_s=%lf", &ate, &trans, &rot),
            3);
  EXPECT_LT(ate, 1e-6);
  EXPECT_LT(trans, 1e-6);
  EXPECT_NE(shifted.err.find("offset_s=-0.3"), std::string::npos) << shifted.err;
  const RunResult bad = run(args + " --offset nan");
  EXPECT_NE(bad.exit_code, 0);
}

TEST_F(CmdEvaluate, BadOptionValueIsRefusedWhereItIsParsed) {
  const fs::path gt = dir_ / "gt.txt";
  std::ofstream(gt) << "1.0 0 0 0 0 0 0 1\n";
  const RunResult r =
      run("evaluate --gt " + quoted(gt.string()) + " --est " + quoted(gt.string()) + " --delta -1");
  EXPECT_EQ(r.exit_code, 105);  // CLI11's validation error, before any file is read
  EXPECT_NE(r.err.find("--delta"), std::string::npos) << r.err;
}

}  // namespace
