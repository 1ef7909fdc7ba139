// `kestrel_ros make-bag` and `kestrel_ros bag` end to end: a bag made from the shared TUM
// folder gives the library's trajectory on that folder; bad inputs give errors naming the file
// or topic; nothing the user wrote is overwritten without --force.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "kestrel/io/trajectory_io.hpp"
#include "library_reference.hpp"
#include "run_ros_cli.hpp"
#include "test_data.hpp"

namespace kestrel::test {
namespace {

namespace fs = std::filesystem;
constexpr std::size_t kFrames = 30;

/// One bag of the first kFrames frames, made once per test program run (named so that the
/// camera is guessed from it, as TUM's own bags are named).
struct BagDir {
  fs::path path = fs::temp_directory_path() / ("kestrel_ros_bags_" + std::to_string(::getpid()));
  ~BagDir() {
    std::error_code ec;
    fs::remove_all(path, ec);  // ~30 MB: not left behind
  }
};

fs::path shared_bag() {
  static BagDir dir_holder;
  static fs::path bag;
  if (!bag.empty()) return bag;
  const fs::path& dir = dir_holder.path;
  fs::create_directories(dir);
  const fs::path out = dir / "rgbd_dataset_freiburg1_rpy_first30.bag";
  const RunResult r = run_kestrel_ros(
      dir, "make-bag --tum " + quoted((shared_data_dir() / kTumRpyPart1).string()) + " --out " +
               quoted(out.string()) + " --max-frames " + std::to_string(kFrames));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  if (r.exit_code == 0) bag = out;
  return bag;
}

void expect_library_trajectory(const fs::path& trajectory_file, const std::string& what) {
  const Trajectory trajectory = io::read_tum_trajectory(trajectory_file);
  const auto reference =
      library_rgbd_trajectory((shared_data_dir() / kTumRpyPart1).string(), "fr1", kFrames);
  ASSERT_EQ(trajectory.size(), reference.size()) << what;
  double max_dp = 0.0, max_dq = 0.0;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    ASSERT_EQ(trajectory[i].t_ns, reference[i].t_ns) << what << ", frame " << i;
    const auto [dp, dq] = pose_difference(trajectory[i].T_world_body.translation(),
                                          trajectory[i].T_world_body.unit_quaternion(),
                                          reference[i].p, reference[i].q);
    max_dp = std::max(max_dp, dp);
    max_dq = std::max(max_dq, dq);
  }
  // The TUM file holds shortest round-trip decimals: the only difference left is the matrix
  // <-> quaternion round trip of the pose, ~1e-16.
  EXPECT_LT(max_dp, 1e-9) << what;
  EXPECT_LT(max_dq, 1e-9) << what;
  std::cout << what << ": " << reference.size() << " poses, max |dp| " << max_dp
            << " m, max rotation difference " << max_dq << " rad\n";
}

TEST(RosBagCli, BagModeGivesTheLibraryTrajectoryOfTheFolder) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path bag = shared_bag();
  ASSERT_FALSE(bag.empty());
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const fs::path out = scratch / "trajectory.txt";
  const RunResult r = run_kestrel_ros(
      scratch, "bag --bag " + quoted(bag.string()) + " --out " + quoted(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("camera (from the bag's name: fr1)"), std::string::npos) << r.err;
  EXPECT_EQ(last_line_of(r.err).rfind("SUMMARY frames=30 failures=", 0), 0u) << r.err;
  EXPECT_EQ(read_text_first_line(out), "# written by kestrel ros bag");
  expect_library_trajectory(out, "bag mode vs library on the folder");
}

TEST(RosBagCli, CameraInfoOfTheBagIsUsedWhenNothingElseSaysTheCamera) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path bag = shared_bag();
  ASSERT_FALSE(bag.empty());
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const fs::path plain = scratch / "recording.bag";  // no freiburgN in the name
  fs::copy_file(bag, plain);
  const fs::path out = scratch / "trajectory.txt";
  const RunResult r = run_kestrel_ros(
      scratch, "bag --bag " + quoted(plain.string()) + " --out " + quoted(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("camera (from /camera/rgb/camera_info)"), std::string::npos) << r.err;
  expect_library_trajectory(out, "bag mode with the bag's camera_info");
  fs::remove(plain);  // 30 MB
}

TEST(RosBagCli, MakeBagRefusesToOverwriteWithoutForce) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const fs::path out = scratch / "mine.bag";
  { std::ofstream(out) << "something the user keeps\n"; }
  const std::string args = "make-bag --tum " + quoted((shared_data_dir() / kTumRpyPart1).string()) +
                           " --out " + quoted(out.string()) + " --max-frames 2";
  const RunResult refused = run_kestrel_ros(scratch, args);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find(out.string() + ": exists; give --force"), std::string::npos)
      << refused.err;
  EXPECT_EQ(read_text_first_line(out), "something the user keeps");
  const RunResult forced = run_kestrel_ros(scratch, args + " --force");
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_GT(fs::file_size(out), 100000u);
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
  fs::remove(out);
}

TEST(RosBagCli, BagModeRefusesToOverwriteAUsersFile) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path bag = shared_bag();
  ASSERT_FALSE(bag.empty());
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const fs::path out = scratch / "notes.txt";
  { std::ofstream(out) << "my notes\n"; }
  const RunResult r = run_kestrel_ros(
      scratch, "bag --bag " + quoted(bag.string()) + " --out " + quoted(out.string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(out.string()), std::string::npos) << r.err;
  EXPECT_EQ(read_text_first_line(out), "my notes");
}

TEST(RosBagCli, MissingOrUnreadableBagsAreNamed) {
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const fs::path missing = scratch / "nowhere.bag";
  RunResult r = run_kestrel_ros(scratch, "bag --bag " + quoted(missing.string()) + " --out " +
                                             quoted((scratch / "t.txt").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(last_line_of(r.err), "kestrel_ros: error: " + missing.string() + ": no such bag file");

  const fs::path text = scratch / "not_a.bag";
  { std::ofstream(text) << "this is not a bag\n"; }
  r = run_kestrel_ros(scratch, "bag --bag " + quoted(text.string()) + " --out " +
                                   quoted((scratch / "t.txt").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(text.string() + ": cannot be read as a ROS bag"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(scratch / "t.txt"));

  r = run_kestrel_ros(scratch, "make-bag --tum " + quoted((scratch / "no_folder").string()) +
                                   " --out " + quoted((scratch / "x.bag").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find((scratch / "no_folder").string() + ": no such folder"), std::string::npos)
      << r.err;
}

TEST(RosBagCli, AMissingTopicIsNamedWithWhatTheBagHas) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path bag = shared_bag();
  ASSERT_FALSE(bag.empty());
  const fs::path scratch = fresh_temp_dir("ros_bag");
  const RunResult r =
      run_kestrel_ros(scratch, "bag --bag " + quoted(bag.string()) + " --out " +
                                   quoted((scratch / "t.txt").string()) +
                                   " --depth-topic /camera/depth_registered/image_raw");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no topic /camera/depth_registered/image_raw (depth images"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("/camera/depth/image (sensor_msgs/Image)"), std::string::npos) << r.err;
  // A topic of the wrong type.
  const RunResult wrong = run_kestrel_ros(scratch, "bag --bag " + quoted(bag.string()) + " --out " +
                                                       quoted((scratch / "t.txt").string()) +
                                                       " --rgb-topic /camera/rgb/camera_info");
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_NE(wrong.err.find("topic /camera/rgb/camera_info holds sensor_msgs/CameraInfo, expected "
                           "sensor_msgs/Image"),
            std::string::npos)
      << wrong.err;
}

}  // namespace
}  // namespace kestrel::test
