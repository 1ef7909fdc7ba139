// Trajectory files: exact time stamps, both formats read and round-tripped, every kind of
// bad input reported with file and line, and the overwrite guard.
#include <gtest/gtest.h>

#include <fstream>
#include <optional>
#include <random>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

/// The message of the InputError that `read` throws on `text`, or "" if it throws none.
template <typename Reader>
std::string error_of(const fs::path& path, const std::string& text, Reader read) {
  write_text(path, text);
  try {
    read(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

Trajectory random_trajectory(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<TimeNs> step_ns(1, 50'000'000);
  Trajectory trajectory;
  TimeNs t_ns = 1'403'715'274'312'143'104;
  for (std::size_t i = 0; i < n; ++i) {
    t_ns += step_ns(rng);
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = 3.0 * u(rng);
    trajectory.push_back({t_ns, SE3::exp(xi)});
  }
  return trajectory;
}

void expect_same(const Trajectory& a, const Trajectory& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns) << i;
    EXPECT_EQ(a[i].T_world_body.translation(), b[i].T_world_body.translation()) << i;
    // Reading renormalises the quaternion, which may move its last bit.
    EXPECT_LT(
        a[i].T_world_body.unit_quaternion().angularDistance(b[i].T_world_body.unit_quaternion()),
        1e-14)
        << i;
  }
}

class TrajectoryIoTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::fresh_temp_dir("trajectory_io"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// A reader whose fail() we can call from parse_seconds_ns(): the file must exist.
class SecondsParsing : public TrajectoryIoTest {
 protected:
  void SetUp() override {
    TrajectoryIoTest::SetUp();
    write_text(dir_ / "dummy.txt", "x\n");
    reader_.emplace(dir_ / "dummy.txt");
  }
  TimeNs parse(const std::string& field) { return parse_seconds_ns(field, *reader_, 0); }
  std::optional<TextLineReader> reader_;
};

TEST_F(SecondsParsing, SplitsAtTheDotExactly) {
  EXPECT_EQ(parse("1305031098.6659"), 1'305'031'098'665'900'000);
  EXPECT_EQ(parse("1305031102.160407"), 1'305'031'102'160'407'000);
  EXPECT_EQ(parse("12"), 12'000'000'000);
  EXPECT_EQ(parse("12."), 12'000'000'000);
  EXPECT_EQ(parse("0.000000001"), 1);
  EXPECT_EQ(parse("1403715274.312143104"), 1'403'715'274'312'143'104);
  // Through a double this stamp would come out 40 ns off (doubles are 256 ns apart here).
  EXPECT_NE(s_to_ns(1305031102.160407), 1'305'031'102'160'407'000);
}

TEST_F(SecondsParsing, RoundsSubNanosecondDigitsHalfUp) {
  EXPECT_EQ(parse("1.0000000005"), 1'000'000'001);
  EXPECT_EQ(parse("1.00000000049999"), 1'000'000'000);
  EXPECT_EQ(parse("1.9999999999"), 2'000'000'000);
}

TEST_F(SecondsParsing, RefusesWhatIsNotDecimalSeconds) {
  for (const std::string bad : {"", ".5", "-1.0", "+1.0", "1e9", "1.2.3", "abc", "1,5", "0x10",
                                "99999999999999999999.0", "9300000000.0"}) {
    EXPECT_THROW(parse(bad), InputError) << "'" << bad << "'";
  }
}

TEST_F(SecondsParsing, FormatRoundTrips) {
  EXPECT_EQ(format_seconds(1'305'031'098'665'900'000), "1305031098.665900");
  EXPECT_EQ(format_seconds(1), "0.000000001");
  EXPECT_EQ(format_seconds(1'403'715'274'312'143'104), "1403715274.312143104");
  EXPECT_EQ(format_seconds(-1'500'000'000), "-1.500000");
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<TimeNs> t(0, 4'000'000'000'000'000'000);
  for (int i = 0; i < 1000; ++i) {
    const TimeNs t_ns = t(rng);
    EXPECT_EQ(parse(format_seconds(t_ns)), t_ns);
  }
}

TEST_F(TrajectoryIoTest, ReadsTheTumReferenceGroundTruth) {
  KESTREL_REQUIRE_DATA("tum/reference_trajectories");
  const Trajectory gt = read_trajectory(test::shared_data_dir() /
                                        "tum/reference_trajectories/freiburg1_xyz-groundtruth.txt");
  ASSERT_EQ(gt.size(), 3000u);
  EXPECT_EQ(gt.front().t_ns, 1'305'031'098'665'900'000);
  // 1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986
  EXPECT_EQ(gt.front().T_world_body.translation(), Eigen::Vector3d(1.3563, 0.6305, 1.6380));
  const Eigen::Quaterniond q(-0.3986, 0.6132, 0.5962, -0.3311);
  EXPECT_LT(gt.front().T_world_body.unit_quaternion().angularDistance(q.normalized()), 1e-12);
}

TEST_F(TrajectoryIoTest, ReadsEurocGroundTruthCsvs) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/groundtruth_cam0/data.csv");
  const fs::path cam0 =
      test::shared_data_dir() / "euroc/V1_01_easy_part1/mav0/groundtruth_cam0/data.csv";
  EXPECT_EQ(detect_trajectory_format(cam0), TrajectoryFormat::kEurocCsv);
  const Trajectory gt = read_trajectory(cam0);
  ASSERT_GT(gt.size(), 100u);
  // 1403715274312143104.0000000000,0.8687393558,2.2070275302,0.9257726725,0.4259596512,...
  EXPECT_EQ(gt.front().t_ns, 1'403'715'274'312'143'104);
  EXPECT_EQ(gt.front().T_world_body.translation(),
            Eigen::Vector3d(0.8687393558, 2.2070275302, 0.9257726725));
  EXPECT_NEAR(std::abs(gt.front().T_world_body.unit_quaternion().w()), 0.4259596512, 1e-9);
}

TEST_F(TrajectoryIoTest, IgnoresExtraEurocColumns) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const Trajectory gt = read_trajectory(test::shared_data_dir() /
                                        "euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  EXPECT_GT(gt.size(), 1000u);
}

TEST_F(TrajectoryIoTest, TumRoundTripIsExact) {
  const Trajectory written = random_trajectory(200, 1);
  write_tum_trajectory(dir_ / "t.txt", written, "test");
  EXPECT_EQ(detect_trajectory_format(dir_ / "t.txt"), TrajectoryFormat::kTum);
  expect_same(written, read_tum_trajectory(dir_ / "t.txt"));
  expect_same(written, read_trajectory(dir_ / "t.txt"));
}

TEST_F(TrajectoryIoTest, EurocRoundTripIsExact) {
  const Trajectory written = random_trajectory(200, 2);
  write_euroc_trajectory(dir_ / "t.csv", written, "test");
  EXPECT_EQ(detect_trajectory_format(dir_ / "t.csv"), TrajectoryFormat::kEurocCsv);
  expect_same(written, read_euroc_trajectory(dir_ / "t.csv"));
  expect_same(written, read_trajectory(dir_ / "t.csv"));
}

TEST_F(TrajectoryIoTest, WritersStartWithTheProvenanceLine) {
  write_tum_trajectory(dir_ / "t.txt", random_trajectory(3, 3), "odometry");
  std::ifstream in(dir_ / "t.txt");
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "# written by kestrel odometry");
}

TEST_F(TrajectoryIoTest, AcceptsCommentsBlankLinesCrlfAndUnheadedCsv) {
  write_text(dir_ / "a.txt",
             "# comment\r\n\r\n1.5 1 2 3 0 0 0 1\r\n  \t\n2.5\t1 2 3 0 0 0 1.0002\r\n");
  const Trajectory a = read_trajectory(dir_ / "a.txt");
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[1].t_ns, 2'500'000'000);
  EXPECT_NEAR(a[1].T_world_body.unit_quaternion().norm(), 1.0, 1e-15);
  write_text(dir_ / "b.csv", "timestamp,x,y,z,qw,qx,qy,qz\n10,1,2,3,1,0,0,0\n20,1,2,3,1,0,0,0\n");
  EXPECT_EQ(read_trajectory(dir_ / "b.csv").size(), 2u);
}

TEST_F(TrajectoryIoTest, EmptyFileIsAnEmptyTrajectory) {
  write_text(dir_ / "e.txt", "# nothing here\n");
  EXPECT_TRUE(read_trajectory(dir_ / "e.txt").empty());
}

struct BadCase {
  const char* name;
  const char* text;
  std::size_t line;
  const char* says;
};

TEST_F(TrajectoryIoTest, EveryBadTumLineNamesFileAndLine) {
  const std::string ok = "# header\n1.0 0 0 0 0 0 0 1\n";
  const BadCase cases[] = {
      {"too few fields", "2.0 0 0 0 0 0 1\n", 3, "expected 8 fields"},
      {"too many fields", "2.0 0 0 0 0 0 0 1 7\n", 3, "expected 8 fields"},
      {"non-numeric value", "2.0 0 zero 0 0 0 0 1\n", 3, "field 3"},
      {"non-numeric stamp", "two 0 0 0 0 0 0 1\n", 3, "field 1"},
      {"NaN", "2.0 0 0 nan 0 0 0 1\n", 3, "field 4"},
      {"infinity", "2.0 0 0 0 inf 0 0 1\n", 3, "field 5"},
      {"zero quaternion", "2.0 0 0 0 0 0 0 0\n", 3, "quaternion is zero"},
      {"non-unit quaternion", "2.0 0 0 0 0 0 0 2\n", 3, "norm"},
      {"time backwards", "0.5 0 0 0 0 0 0 1\n", 3, "backwards"},
      {"duplicate time", "1.000 0 0 0 0 0 0 1\n", 3, "duplicate"},
      {"csv line in TUM", "3.0,0,0,0,0,0,0,1\n", 3, "expected 8 fields"},
  };
  for (const BadCase& c : cases) {
    const fs::path path = dir_ / "bad.txt";
    const std::string message = error_of(path, ok + c.text, read_tum_trajectory);
    EXPECT_NE(message.find(path.string() + ":" + std::to_string(c.line) + ":"), std::string::npos)
        << c.name << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.name << ": " << message;
  }
}

TEST_F(TrajectoryIoTest, EveryBadEurocLineNamesFileAndLine) {
  const std::string ok = "#timestamp [ns],x,y,z,qw,qx,qy,qz\n1000,0,0,0,1,0,0,0\n";
  const BadCase cases[] = {
      {"too few fields", "2000,0,0,0,1,0,0\n", 3, "at least 8"},
      {"empty field", "2000,0,,0,1,0,0,0\n", 3, "field 3"},
      {"non-numeric stamp", "2e3,0,0,0,1,0,0,0\n", 3, "field 1"},
      {"fractional stamp", "2000.5,0,0,0,1,0,0,0\n", 3, "field 1"},
      {"NaN", "2000,0,0,NaN,1,0,0,0\n", 3, "field 4"},
      {"zero quaternion", "2000,0,0,0,0,0,0,0\n", 3, "quaternion is zero"},
      {"non-unit quaternion", "2000,0,0,0,0.5,0,0,0\n", 3, "norm"},
      {"time backwards", "999,0,0,0,1,0,0,0\n", 3, "backwards"},
      {"duplicate time", "1000.000,0,0,0,1,0,0,0\n", 3, "duplicate"},
  };
  for (const BadCase& c : cases) {
    const fs::path path = dir_ / "bad.csv";
    const std::string message = error_of(path, ok + c.text, read_euroc_trajectory);
    EXPECT_NE(message.find(path.string() + ":" + std::to_string(c.line) + ":"), std::string::npos)
        << c.name << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.name << ": " << message;
  }
}

TEST_F(TrajectoryIoTest, MissingFileIsAnInputErrorNamingIt) {
  try {
    read_trajectory(dir_ / "missing.txt");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.txt"), std::string::npos) << e.what();
  }
}

TEST_F(TrajectoryIoTest, WriterRefusesToOverwriteAForeignFile) {
  const fs::path path = dir_ / "notes.txt";
  write_text(path, "my own notes\n");
  EXPECT_THROW(write_tum_trajectory(path, random_trajectory(3, 4), "test"), InputError);
  EXPECT_THROW(write_euroc_trajectory(path, random_trajectory(3, 4), "test"), InputError);
  std::ifstream in(path);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "my own notes");  // untouched
  // Another Kestrel command's output is foreign too; the same command may rewrite its own.
  write_tum_trajectory(dir_ / "own.txt", random_trajectory(3, 5), "odometry");
  EXPECT_THROW(write_tum_trajectory(dir_ / "own.txt", random_trajectory(3, 6), "fuse"), InputError);
  EXPECT_NO_THROW(write_tum_trajectory(dir_ / "own.txt", random_trajectory(3, 6), "odometry"));
  EXPECT_NO_THROW(write_tum_trajectory(path, random_trajectory(3, 4), "test", /*force=*/true));
}

}  // namespace
}  // namespace kestrel::io
