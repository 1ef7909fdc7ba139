// Numeric options outside their sense are refused before any work, with a message naming the
// option and the allowed range, and nothing is written: the cases a hostile but fair user tried
// (a count of -1 that wrapped to 1.8e19 frames, a pattern of two billion lines, a duration of 0
// or nan that silently flew the default, a negative latency that was ignored).
#include <gtest/gtest.h>

#include <string>

#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

class OptionRanges : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    dir_ = kestrel::test::fresh_temp_dir("option_ranges");
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs `kestrel <command> ... --out <dir>/out` and checks the refusal.
  void expect_refused(const std::string& arguments, const std::string& option) const {
    const fs::path out = dir_ / "out";
    const RunResult r =
        kestrel::test::run_kestrel(dir_, arguments + " --out " + quoted(out.string()));
    EXPECT_NE(r.exit_code, 0) << arguments;
    EXPECT_NE(r.err.find(option), std::string::npos) << arguments << ": " << r.err;
    EXPECT_NE(r.err.find("expected"), std::string::npos) << arguments << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << arguments << " wrote " << out;
  }

  fs::path dir_;
};

TEST_F(OptionRanges, RenderRefusesCountsAndDurationsOutsideTheirSense) {
  const std::string render = "render --scene office --trajectory still";
  expect_refused(render + " --frames -1", "--frames");
  expect_refused(render + " --frames 0", "--frames");
  expect_refused(render + " --frames 1e12", "--frames");
  expect_refused(render + " --duration -1", "--duration");
  expect_refused(render + " --duration nan", "--duration");
  expect_refused(render + " --rate 0", "--rate");
  expect_refused(render + " --rate inf", "--rate");
}

TEST_F(OptionRanges, PatternRefusesAnUnboundedLineCount) {
  expect_refused("pattern --lines 2000000000", "--lines");
  expect_refused("pattern --lines 0", "--lines");
}

TEST_F(OptionRanges, FlyRefusesDurationsAndLatenciesOutsideTheirSense) {
  expect_refused("fly --scenario hover --duration 0", "--duration");
  expect_refused("fly --scenario hover --duration nan", "--duration");
  expect_refused("fly --scenario hover --duration inf", "--duration");
  expect_refused("fly --scenario hover --latency -1", "--latency");
  expect_refused("fly --scenario hover --latency 5", "--latency");
  expect_refused("fly --scenario hover --vo-off-at 1 --vo-off-for 0", "--vo-off-for");
}

TEST_F(OptionRanges, ValuesInsideTheRangeStillRun) {
  const fs::path out = dir_ / "pattern.png";
  const RunResult r = kestrel::test::run_kestrel(
      dir_, "pattern --lines 5 --width 64 --height 48 --out " + quoted(out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
}

}  // namespace
