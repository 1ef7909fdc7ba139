// Numeric options outside their sense are refused before any work, with a message naming the
// option and the allowed range, and nothing is written: the cases a hostile but fair user tried
// (a count of -1 that wrapped to 1.8e19 frames, a pattern of two billion lines, a duration of 0
// or nan that silently flew the default, a negative latency that was ignored).
//
// The first tests walk the command tree itself (kestrel_cli's add_commands), so a numeric option
// added without a range check fails here, whatever command it is on.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "option_checks.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;

// ---- Every numeric option of the command tree ----------------------------------------------

/// One numeric option: its command path ("lab stereo-experiment") and name ("--block").
struct NumericOption {
  std::string command;
  std::string name;
  CLI::Option* option;
  [[nodiscard]] std::string label() const { return "kestrel " + command + " " + name; }
};

/// CLI11's type names of numbers (integral, unsigned, floating point). get_type_name() appends
/// each validator's description after a ':' ("INT:a whole number ..."): the type is before it.
bool is_numeric(const CLI::Option* o) {
  const std::string full = o->get_type_name();
  const std::string t = full.substr(0, full.find(':'));
  return t == "INT" || t == "UINT" || t == "FLOAT" || t == "NUMBER";
}

void collect(CLI::App* app, const std::string& path, std::vector<NumericOption>& out) {
  for (CLI::Option* o : app->get_options()) {
    if (!is_numeric(o)) continue;
    // The long name ("--block"); a positional has only its name.
    const std::string name = o->get_lnames().empty() ? o->get_name() : "--" + o->get_lnames()[0];
    out.push_back({path, name, o});
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
    collect(sub, path.empty() ? sub->get_name() : path + " " + sub->get_name(), out);
  }
}

class CommandTree : public ::testing::Test {
 protected:
  void SetUp() override {
    kestrel::cli::add_commands(app_);
    collect(&app_, "", options_);
    // The walk must see the commands' options, or the checks below prove nothing.
    ASSERT_GE(options_.size(), 60U) << "the walk found too few numeric options";
  }
  /// The option's range check, or nullptr.
  static CLI::Validator* range_check(const NumericOption& o) {
    try {
      return o.option->get_validator(kestrel::cli::kRangeCheck);
    } catch (const CLI::OptionNotFound&) {
      return nullptr;
    }
  }

  CLI::App app_{"kestrel"};
  std::vector<NumericOption> options_;
};

// In-range values of the numeric options that show no default (the default is "not given"),
// for the check that a good value passes; every other numeric option is checked with its
// default. A numeric option with neither fails the test, so this list must grow with them.
const std::map<std::string, std::string>& good_values_without_default() {
  static const std::map<std::string, std::string> values = {
      {"kestrel odometry --depth-scale", "1000"},
      {"kestrel odometry --block", "7"},
      {"kestrel odometry --max-disparity", "128"},
      {"kestrel odometry --min-disparity", "0"},
      {"kestrel disparity --min-depth", "0.2"},
      {"kestrel disparity --max-depth", "20"},
      {"kestrel capture --frames", "100"},
      {"kestrel capture --duration", "10"},
      {"kestrel capture --rate", "30"},
      {"kestrel render --duration", "3"},
      {"kestrel fly --duration", "30"},
      {"kestrel fly --latency", "0.04"},
      {"kestrel fly --vo-off-at", "10"},
      {"kestrel fly --vo-off-for", "2"},
      {"kestrel fly --adaptive-vo-noise-max-scale", "16"},
      {"kestrel fuse --imu-noise-inflation", "15"},
      {"kestrel lab fuse-eval --time-offset-ms", "15"},
      {"kestrel lab fuse-eval --extrinsic-sigma-deg", "2"},
      {"kestrel lab fuse-eval --imu-rotation-deg", "-1.5"},
      {"kestrel lab fuse-eval --gyro-scale", "1.01"},
      {"kestrel lab fuse-eval --world-rotation-deg", "0.5"},
  };
  return values;
}

TEST_F(CommandTree, EveryNumericOptionOfEveryCommandHasARangeCheck) {
  for (const auto& o : options_) {
    EXPECT_NE(range_check(o), nullptr)
        << o.label() << " (" << o.option->get_type_name()
        << ") has no range check: add ->check(number_in(...)) or ->check(whole_in(...)) "
           "(apps/kestrel/option_checks.hpp) where it is declared";
  }
}

TEST_F(CommandTree, RangeChecksRefuseNonFiniteHugeAndMalformedValues) {
  for (const auto& o : options_) {
    CLI::Validator* check = range_check(o);
    if (check == nullptr) continue;  // reported by the test above
    for (std::string bad : {"nan", "inf", "-inf", "1e300", "-1e300", "9223372036854775808",
                            "-9223372036854775809", "abc", "", "1x"}) {
      const std::string text = bad;
      const std::string message = (*check)(bad);
      EXPECT_NE(message.find("expected"), std::string::npos)
          << o.label() << " accepted '" << text << "' (message: '" << message << "')";
    }
  }
}

TEST_F(CommandTree, DefaultsAndGoodValuesPassTheirRangeCheck) {
  for (const auto& o : options_) {
    CLI::Validator* check = range_check(o);
    if (check == nullptr) continue;
    std::string good = o.option->get_default_str();
    if (good.empty()) {
      const auto it = good_values_without_default().find(o.label());
      if (it == good_values_without_default().end()) {
        ADD_FAILURE()
            << o.label()
            << " shows no default: add an in-range value to good_values_without_default()";
        continue;
      }
      good = it->second;
    }
    const std::string text = good;
    EXPECT_EQ((*check)(good), "") << o.label() << " refuses the good value " << text;
  }
}

TEST_F(CommandTree, ParsingABadValueIsRefusedNamingTheOptionAndItsRange) {
  for (const auto& o : options_) {
    if (range_check(o) == nullptr) continue;  // would run the command
    // A fresh tree per parse: CLI11 keeps what it parsed.
    CLI::App app{"kestrel"};
    kestrel::cli::add_commands(app);
    std::vector<std::string> argv = {"kestrel"};
    for (std::size_t start = 0; start < o.command.size();) {
      const auto end = std::min(o.command.find(' ', start), o.command.size());
      argv.push_back(o.command.substr(start, end - start));
      start = end + 1;
    }
    if (o.name.rfind("--", 0) == 0) argv.push_back(o.name);
    argv.push_back("nan");
    std::vector<char*> c_argv;
    for (auto& a : argv) c_argv.push_back(a.data());
    try {
      app.parse(static_cast<int>(c_argv.size()), c_argv.data());
      ADD_FAILURE() << o.label() << " nan: parsed without error";
    } catch (const CLI::ValidationError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("expected"), std::string::npos) << o.label() << ": " << message;
      if (o.name.rfind("--", 0) == 0) {
        EXPECT_NE(message.find(o.name), std::string::npos) << o.label() << ": " << message;
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << o.label()
                    << " nan: refused by something other than its range check: " << e.what();
    }
  }
}

// ---- End to end: the binary refuses before any work ------------------------------------------
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
  expect_refused("fly --scenario hover --adaptive-vo-noise-max-scale -1",
                 "--adaptive-vo-noise-max-scale");
  expect_refused("fly --scenario hover --adaptive-vo-noise-max-scale nan",
                 "--adaptive-vo-noise-max-scale");
}

TEST_F(OptionRanges, StereoOdometryRefusesAnEmptyDisparityRangeAndBadWindows) {
  // Were silently replaced by the defaults 64 and 9.
  const fs::path dataset = dir_ / "dataset";
  fs::create_directories(dataset);
  const std::string odometry = "odometry --stereo " + quoted(dataset.string());
  expect_refused(odometry + " --max-disparity 0", "--max-disparity");
  expect_refused(odometry + " --block 0", "--block");
  expect_refused(odometry + " --block 8", "--block");  // even
  expect_refused(odometry + " --min-disparity -1", "--min-disparity");
}

TEST_F(OptionRanges, DepthScaleIsAFiniteNumberWithAReadableRange) {
  const fs::path dataset = dir_ / "dataset";
  fs::create_directories(dataset);
  for (const std::string bad : {"0", "nan", "inf", "-5000"}) {
    const fs::path out = dir_ / "out";
    const RunResult r = kestrel::test::run_kestrel(dir_, "odometry " + quoted(dataset.string()) +
                                                             " --depth-scale " + bad + " --out " +
                                                             quoted(out.string()));
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_NE(r.err.find("--depth-scale"), std::string::npos) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("(0, 1000000]"), std::string::npos) << bad << ": " << r.err;
    // CLI::PositiveNumber printed the range up to DBL_MAX: 309 digits.
    EXPECT_LT(r.err.size(), 400U) << bad << ": " << r.err;
  }
}

TEST_F(OptionRanges, EvaluateRefusesAnAssociationWindowThatOverflowsNanoseconds) {
  // 1e10 s is 1e19 ns, past int64: signed overflow (UBSan) in the association.
  const fs::path gt = dir_ / "gt.txt";
  std::ofstream(gt) << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n";
  const RunResult r =
      kestrel::test::run_kestrel(dir_, "evaluate --gt " + quoted(gt.string()) + " --est " +
                                           quoted(gt.string()) + " --max-diff 1e10");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--max-diff"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(0, 3600] s"), std::string::npos) << r.err;
}

TEST_F(OptionRanges, CaptureDecodeFileThatIsAFolderIsRefusedClearly) {
  // Said "basic_filebuf::underflow".
  const RunResult r =
      kestrel::test::run_kestrel(dir_, "capture --decode-file " + quoted(dir_.string()) +
                                           " --out " + quoted((dir_ / "out").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--decode-file"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("directory"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("underflow"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(OptionRanges, ValuesInsideTheRangeStillRun) {
  const fs::path out = dir_ / "pattern.png";
  const RunResult r = kestrel::test::run_kestrel(
      dir_, "pattern --lines 5 --width 64 --height 48 --out " + quoted(out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
}

}  // namespace
