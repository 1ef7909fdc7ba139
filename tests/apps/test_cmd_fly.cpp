// `kestrel fly` end to end: a one-second flight writes its logs, plots and summary line; bad
// arguments fail clearly; a folder of other files is not overwritten.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_test.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

class CmdFly : public kestrel::test::CliTest {
 protected:
  std::string out(const std::string& name) const { return quoted((dir_ / name).string()); }
};

TEST_F(CmdFly, ShortHoverWritesLogPlotsAndSummary) {
  const RunResult r = run("fly --scenario hover --duration 1 --out " + out("flight"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string last = r.last_line();
  EXPECT_EQ(last.rfind("rms_tracking_m=", 0), 0u) << last;
  EXPECT_NE(last.find(" rms_estimate_m="), std::string::npos) << last;
  EXPECT_NE(last.find(" crashed=0"), std::string::npos) << last;
  for (const char* file : {"log.csv", "details.csv", "top_view.png", "errors.png"}) {
    EXPECT_TRUE(fs::exists(dir_ / "flight" / file)) << file;
  }
  EXPECT_NE(r.out.find("top_view.png"), std::string::npos) << "plot paths are printed";
}

TEST_F(CmdFly, UnknownScenarioIsAClearError) {
  const RunResult r = run("fly --scenario loop --out " + out("flight"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("unknown scenario 'loop'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "flight")) << "nothing is written for a bad argument";
}

TEST_F(CmdFly, MissingOutputAndBadOutageAreErrors) {
  EXPECT_NE(run("fly --scenario hover").err.find("--out"), std::string::npos);
  const RunResult r = run("fly --scenario hover --duration 2 --vo-off-at 5 --out " + out("flight"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--vo-off-at"), std::string::npos) << r.err;
}

TEST_F(CmdFly, RefusesAFolderOfOtherFiles) {
  fs::create_directories(dir_ / "mine");
  { std::ofstream(dir_ / "mine" / "notes.txt") << "precious\n"; }
  const RunResult r = run("fly --scenario hover --duration 0.2 --out " + out("mine"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("refusing"), std::string::npos) << r.err;
  EXPECT_EQ(kestrel::test::slurp(dir_ / "mine" / "notes.txt"), "precious\n");
}

// A safety file's hold_flies_mission that the flight's mission clock overrides is named in a
// warning; one that agrees with it is not.
TEST_F(CmdFly, OverriddenHoldSettingIsWarnedAbout) {
  { std::ofstream(dir_ / "safety.yaml") << "safety:\n  hold_flies_mission: false\n"; }
  const std::string safety = " --safety " + out("safety.yaml");
  const RunResult r = run("fly --scenario hover --duration 0.2" + safety + " --out " + out("a"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("safety.yaml: hold_flies_mission is true in this flight"), std::string::npos)
      << r.err;
  const RunResult agree = run("fly --scenario hover --duration 0.2 --mission-runs-in-hold" +
                              safety + " --out " + out("b"));
  ASSERT_EQ(agree.exit_code, 0) << agree.err;
  EXPECT_EQ(agree.err.find("hold_flies_mission"), std::string::npos) << agree.err;
}

// --stereo-matcher picks the vision's matcher (the start-up line names it); a bad name, or SGM
// options without sgm, is an error naming the flag.
TEST_F(CmdFly, StereoMatcherSelectsTheMatcher) {
  const RunResult r =
      run("fly --scenario hover --duration 0.5 --stereo-matcher sgm --out " + out("flight"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("grey levels, sgm (paths 8)"), std::string::npos) << r.err;
  const RunResult bad = run("fly --stereo-matcher sgbm --out " + out("bad"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("--stereo-matcher: must be sad, census or sgm"), std::string::npos)
      << bad.err;
  { std::ofstream(dir_ / "sgm.yaml") << "paths: 4\n"; }
  const RunResult stray = run("fly --sgm-options " + out("sgm.yaml") + " --out " + out("bad"));
  EXPECT_EQ(stray.exit_code, 1);
  EXPECT_NE(stray.err.find("'--sgm-options': is for --stereo-matcher: sgm"), std::string::npos)
      << stray.err;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

TEST_F(CmdFly, ListNamesEveryScenario) {
  const RunResult r = run("fly --list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* name : {"hover", "square", "corridor"}) {
    EXPECT_NE(r.out.find(name), std::string::npos) << name;
  }
}

}  // namespace
