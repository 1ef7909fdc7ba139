// `kestrel fuse` end to end on a small generated input: a simulated 6 s flight gives an
// EuRoC IMU CSV, a TUM camera trajectory (noisy 20 Hz odometry, chained), a sensor YAML with
// T_body_cam and a TUM initial body pose; the built binary (KESTREL_BINARY) must write one
// fused body pose per odometry frame close to the truth, and fail clearly on a bad calibration.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>

#include "kestrel/lab/fusion_simulation.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

namespace kestrel::fusion {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::RunResult;
using test::slurp;

constexpr TimeNs kT0 = 1'403'715'000'000'000'000;  // EuRoC-like absolute time stamps

std::string tum_line(TimeNs t_ns, const SE3& T) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(9) << ns_to_s(t_ns) << " ";
  const Eigen::Quaterniond q = T.unit_quaternion();
  s << T.translation().x() << " " << T.translation().y() << " " << T.translation().z() << " "
    << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
  return s.str();
}

class CmdFuse : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    dir_ = test::fresh_temp_dir("cmd_fuse");
    generate();
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& arguments) const { return test::run_kestrel(dir_, arguments); }

  void write_calib(const fs::path& path, bool with_gyro_noise) {
    std::ofstream y(path);
    y << "%YAML:1.0\nsensor_type: imu\nrate_hz: 200\n";
    if (with_gyro_noise) y << "gyroscope_noise_density: " << options_.noise.gyro_noise << "\n";
    y << "gyroscope_random_walk: " << options_.noise.gyro_walk << "\n"
      << "accelerometer_noise_density: " << options_.noise.accel_noise << "\n"
      << "accelerometer_random_walk: " << options_.noise.accel_walk << "\n"
      << "T_body_cam:\n  rows: 4\n  cols: 4\n  data: [";
    const Eigen::Matrix4d T = sim_.T_body_cam.matrix();
    for (int i = 0; i < 16; ++i)
      y << std::setprecision(17) << T(i / 4, i % 4) << (i < 15 ? ", " : "]\n");
  }

  void generate() {
    sim_.duration_s = 6.0;
    options_.init_sigma_gyro_bias_rad_s = 0.002;  // small simulated biases
    options_.init_sigma_accel_bias_m_s2 = 0.02;
    std::mt19937_64 rng(7);
    run_ = lab::simulate_run(flight_, sim_, options_, rng);
    {
      std::ofstream imu(dir_ / "imu.csv");
      imu << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
             "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
      imu << std::setprecision(17);
      for (const auto& s : run_.imu) {
        imu << kT0 + s.t_ns << "," << s.gyro_rad_s.x() << "," << s.gyro_rad_s.y() << ","
            << s.gyro_rad_s.z() << "," << s.accel_m_s2.x() << "," << s.accel_m_s2.y() << ","
            << s.accel_m_s2.z() << "\n";
      }
    }
    // Odometry: the noisy relative motions chained from the true first camera pose.
    std::ofstream vo(dir_ / "vo.txt");
    SE3 T_w_c = flight_.at(0.0).T_world_body * sim_.T_body_cam;
    vo << tum_line(kT0, T_w_c);
    for (const auto& m : run_.odometry) {
      T_w_c = T_w_c * m.T_ref_cur;
      vo << tum_line(kT0 + m.t_ns, T_w_c);
      truth_.push_back({kT0 + m.t_ns, flight_.at(ns_to_s(m.t_ns)).T_world_body});
    }
    const SE3 chained_body = T_w_c * sim_.T_body_cam.inverse();
    chained_final_rot_deg_ =
        (truth_.back().second.so3().inverse() * chained_body.so3()).angle() * 180.0 / M_PI;
    // Initial body state: the true body trajectory over the first 0.1 s.
    std::ofstream init(dir_ / "init.txt");
    for (TimeNs t = 0; t <= s_to_ns(0.1); t += s_to_ns(0.005)) {
      init << tum_line(kT0 + t, flight_.at(ns_to_s(t)).T_world_body);
    }
    write_calib(dir_ / "imu.yaml", true);
    write_calib(dir_ / "imu_missing.yaml", false);
  }

  std::string common_args(const fs::path& calib) {
    return "fuse --imu " + quoted((dir_ / "imu.csv").string()) + " --vo " +
           quoted((dir_ / "vo.txt").string()) + " --calib " + quoted(calib.string()) + " --init " +
           quoted((dir_ / "init.txt").string()) + " --out " + quoted((dir_ / "fused.txt").string());
  }

  fs::path dir_;
  lab::SimulatedFlight flight_{5};
  lab::SimulationOptions sim_;
  FusionOptions options_;
  lab::SimulatedRun run_;
  std::vector<std::pair<TimeNs, SE3>> truth_;
  double chained_final_rot_deg_ = 0.0;
};

TEST_F(CmdFuse, WritesOneAccurateBodyPosePerOdometryFrame) {
  const RunResult r =
      run(common_args(dir_ / "imu.yaml") + " --states " + quoted((dir_ / "states.txt").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("accepted updates: "), std::string::npos) << r.out;
  std::ifstream in(dir_ / "fused.txt");
  std::string line;
  std::size_t n = 0, matched = 0;
  double worst_p = 0.0, worst_rot_deg = 0.0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t, x, y, z, qx, qy, qz, qw;
    ASSERT_TRUE(static_cast<bool>(s >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) << line;
    ++n;
    for (const auto& [tt, T] : truth_) {
      if (std::llabs(tt - s_to_ns(t)) > 1'000'000) continue;
      ++matched;
      const SE3 F(Eigen::Quaterniond(qw, qx, qy, qz).normalized(), Eigen::Vector3d(x, y, z));
      worst_p = std::max(worst_p, (F.translation() - T.translation()).norm());
      worst_rot_deg = std::max(worst_rot_deg, (T.so3().inverse() * F.so3()).angle() * 180.0 / M_PI);
    }
  }
  // One fused pose per odometry frame after the first (which only starts the reference).
  EXPECT_EQ(n, truth_.size());
  EXPECT_EQ(matched, truth_.size());
  // 6 s of 1 cm / 0.5 deg odometry with the default gyro-bias prior (0.01 rad/s): the filter
  // reports 1-sigma 0.12 m per axis and 0.05 rad in yaw at the end (the unknown yaw-axis gyro
  // bias integrates; 0.5 deg relative rotations teach it slowly), measured worst errors
  // 0.24 m and 2.3 deg. Bounds at about 3 sigma, and better than chaining the odometry.
  std::cout << "consecutive poses: worst position error " << worst_p << " m\n";
  EXPECT_LT(worst_p, 0.45);
  EXPECT_LT(worst_rot_deg, 6.0);
  EXPECT_LT(worst_rot_deg, chained_final_rot_deg_ + 1.0);
  EXPECT_TRUE(fs::exists(dir_ / "states.txt"));
  EXPECT_NE(slurp(dir_ / "states.txt").find("updated"), std::string::npos);
}

// --vo-frames: the odometry's keyframes and covariances from a `kestrel odometry --frames` log.
// The same simulated motions, grouped into keyframes of 5 frames: each frame's motion from its
// keyframe is the chain of its noisy increments (the chained poses of vo.txt), its covariance
// the sum of theirs.
TEST_F(CmdFuse, FrameLogGivesKeyframeMeasurementsAsAccurateAsConsecutivePoses) {
  constexpr int kPerKeyframe = 5;
  {
    std::ofstream csv(dir_ / "frames.csv");
    csv << "# written by kestrel odometry\nframe,t_ns,ref_t_ns,ok,new_keyframe";
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) csv << ",cov_" << r << c;
    }
    csv << "\n" << std::setprecision(17);
    const double sp2 = sim_.vo_sigma_p_m * sim_.vo_sigma_p_m;
    const double sr = sim_.vo_sigma_rot_deg * M_PI / 180.0;
    auto row = [&](int frame, TimeNs t, TimeNs ref, bool keyframe, int steps) {
      csv << frame << "," << t << "," << ref << ",1," << (keyframe ? 1 : 0);
      for (int r = 0; r < 6; ++r) {
        for (int c = r; c < 6; ++c) csv << "," << (r == c ? steps * (r < 3 ? sp2 : sr * sr) : 0.0);
      }
      csv << "\n";
    };
    row(0, kT0, kT0, true, 0);
    TimeNs keyframe_t = kT0;
    for (std::size_t i = 0; i < run_.odometry.size(); ++i) {
      const TimeNs t = kT0 + run_.odometry[i].t_ns;
      const int steps = static_cast<int>(i % kPerKeyframe) + 1;
      const bool keyframe = steps == kPerKeyframe;
      row(static_cast<int>(i) + 1, t, keyframe_t, keyframe, steps);
      if (keyframe) keyframe_t = t;
    }
  }
  const RunResult r = run(common_args(dir_ / "imu.yaml") + " --vo-frames " +
                          quoted((dir_ / "frames.csv").string()) + " --vo-cov-scale 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("measurements from " + std::to_string(run_.odometry.size() + 1) + " frames"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("reference keyframe"), std::string::npos) << r.err;
  double worst_p = 0.0;
  std::size_t matched = 0;
  std::ifstream in(dir_ / "fused.txt");
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    double t, x, y, z;
    ASSERT_TRUE(static_cast<bool>(ls >> t >> x >> y >> z)) << line;
    for (const auto& [tt, T] : truth_) {
      if (std::llabs(tt - s_to_ns(t)) > 1'000'000) continue;
      ++matched;
      worst_p = std::max(worst_p, (Eigen::Vector3d(x, y, z) - T.translation()).norm());
    }
  }
  EXPECT_EQ(matched, truth_.size());
  std::cout << "frame log: worst position error " << worst_p << " m\n";
  EXPECT_LT(worst_p, 0.45);  // the bound of the consecutive-pose test above

  // A log without the covariance columns, or together with --vo-cov: errors naming them.
  {
    std::ofstream(dir_ / "short.csv") << "t_ns,ref_t_ns,ok,new_keyframe\n"
                                      << kT0 << "," << kT0 << ",1,1\n";
  }
  const RunResult bad = run(common_args(dir_ / "imu.yaml") + " --force --vo-frames " +
                            quoted((dir_ / "short.csv").string()));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("no column 'cov_00'"), std::string::npos) << bad.err;
  const RunResult both = run(common_args(dir_ / "imu.yaml") + " --force --vo-frames " +
                             quoted((dir_ / "frames.csv").string()) + " --vo-cov " +
                             quoted((dir_ / "frames.csv").string()));
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.err.find("exclude each other"), std::string::npos) << both.err;
}

// The fused positions of a TUM file, by time stamp.
std::vector<std::pair<double, Eigen::Vector3d>> read_positions(const fs::path& path) {
  std::vector<std::pair<double, Eigen::Vector3d>> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    double t, x, y, z;
    if (ls >> t >> x >> y >> z) out.emplace_back(t, Eigen::Vector3d(x, y, z));
  }
  return out;
}

// Copies the IMU CSV, passing each data row through `edit(index, row)` (false drops the row).
template <typename Edit>
void rewrite_imu(const fs::path& from, const fs::path& to, Edit edit) {
  std::ifstream in(from);
  std::ofstream out(to);
  std::size_t k = 0;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '#') {
      out << line << "\n";
      continue;
    }
    if (edit(k++, line)) out << line << "\n";
  }
}

// One accelerometer value of 1e3 m/s^2 (102 g, beyond the default 16 g full scale) at 3 s:
// rejected, named in the summary and in a warning with its line, and the fused poses stay on
// those of the clean IMU. With the range opened (--options) the same file moves them.
TEST_F(CmdFuse, SpikedImuSampleIsRejectedAndTheFusedPosesStayOnTheCleanOnes) {
  const RunResult clean = run(common_args(dir_ / "imu.yaml"));
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_NE(clean.out.find("rejected: nothing"), std::string::npos) << clean.out;
  fs::rename(dir_ / "fused.txt", dir_ / "clean.txt");
  std::size_t spiked_line = 0;
  rewrite_imu(dir_ / "imu.csv", dir_ / "imu_spiked.csv", [&](std::size_t k, std::string& row) {
    if (k == 600) {  // t = 3 s; "t,wx,wy,wz,ax,..." -> ax = 1000
      std::vector<std::string> f;
      std::istringstream ss(row);
      for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
      f[4] = "1000";
      row.clear();
      for (std::size_t i = 0; i < f.size(); ++i) row += (i ? "," : "") + f[i];
      spiked_line = k + 2;  // one header line, 1-based
    }
    return true;
  });
  const std::string args = "fuse --imu " + quoted((dir_ / "imu_spiked.csv").string()) + " --vo " +
                           quoted((dir_ / "vo.txt").string()) + " --calib " +
                           quoted((dir_ / "imu.yaml").string()) + " --init " +
                           quoted((dir_ / "init.txt").string()) + " --out " +
                           quoted((dir_ / "fused.txt").string());
  const RunResult spiked = run(args);
  ASSERT_EQ(spiked.exit_code, 0) << spiked.err;
  EXPECT_NE(spiked.out.find("rejected: 1 IMU samples beyond the sensor's range"), std::string::npos)
      << spiked.out;
  EXPECT_NE(spiked.err.find("imu_spiked.csv:" + std::to_string(spiked_line) + ": sample beyond"),
            std::string::npos)
      << spiked.err;
  const auto a = read_positions(dir_ / "clean.txt");
  const auto b = read_positions(dir_ / "fused.txt");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), truth_.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, (a[i].second - b[i].second).norm());
  std::cout << "spiked IMU: fused poses within " << worst << " m of the clean run's\n";
  EXPECT_LT(worst, 0.005);

  std::ofstream(dir_ / "open.yaml") << "accelerometer_range_m_s2: 1.0e6\n";
  const RunResult open = run(args + " --force --options " + quoted((dir_ / "open.yaml").string()));
  ASSERT_EQ(open.exit_code, 0) << open.err;
  const auto c = read_positions(dir_ / "fused.txt");
  ASSERT_EQ(a.size(), c.size());
  double worst_open = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst_open = std::max(worst_open, (a[i].second - c[i].second).norm());
  std::cout << "spiked IMU, range opened: " << worst_open << " m\n";
  EXPECT_GT(worst_open, 0.05);
}

// The IMU ends at 3 s of the 6 s of odometry: the measurements more than imu_horizon_s (0.5 s)
// after its last sample are refused (no pose written for them, a warning and the summary say
// so), and the poses written stay as close to the truth as in the full run.
TEST_F(CmdFuse, ImuEndingEarlyRefusesTheOdometryBeyondTheHorizon) {
  const TimeNs imu_end = kT0 + s_to_ns(3.0);
  rewrite_imu(dir_ / "imu.csv", dir_ / "imu_short.csv", [&](std::size_t, const std::string& row) {
    return std::stoll(row.substr(0, row.find(','))) <= imu_end;
  });
  const RunResult r =
      run("fuse --imu " + quoted((dir_ / "imu_short.csv").string()) + " --vo " +
          quoted((dir_ / "vo.txt").string()) + " --calib " + quoted((dir_ / "imu.yaml").string()) +
          " --init " + quoted((dir_ / "init.txt").string()) + " --out " +
          quoted((dir_ / "fused.txt").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::size_t beyond = 0;
  for (const auto& [t, T] : truth_) beyond += t > imu_end + s_to_ns(0.5) ? 1 : 0;
  ASSERT_GT(beyond, 0u);
  EXPECT_NE(
      r.out.find(std::to_string(beyond) + " odometry measurements outside the IMU's time coverage"),
      std::string::npos)
      << r.out;
  EXPECT_NE(r.err.find("refused, no pose written"), std::string::npos) << r.err;
  const auto fused = read_positions(dir_ / "fused.txt");
  EXPECT_EQ(fused.size(), truth_.size() - beyond);
  double worst = 0.0;
  for (const auto& [t, p] : fused) {
    EXPECT_LE(s_to_ns(t), imu_end + s_to_ns(0.5) + 1000);
    for (const auto& [tt, T] : truth_) {
      if (std::llabs(tt - s_to_ns(t)) <= 1'000'000)
        worst = std::max(worst, (p - T.translation()).norm());
    }
  }
  EXPECT_LT(worst, 0.45);  // the bound of the full run
}

// Odometry (and its initial state) that starts after the IMU has ended: nothing can be fused,
// an error naming the IMU file, not poses extrapolated on its last reading with exit 0.
TEST_F(CmdFuse, OdometryStartingAfterTheImuIsAnError) {
  rewrite_imu(dir_ / "imu.csv", dir_ / "imu_first.csv", [&](std::size_t, const std::string& row) {
    return std::stoll(row.substr(0, row.find(','))) <= kT0 + s_to_ns(0.5);
  });
  {
    std::ofstream vo(dir_ / "vo_late.txt");
    std::ofstream init(dir_ / "init_long.txt");
    for (TimeNs t = 0; t <= s_to_ns(6.0); t += s_to_ns(0.05)) {
      init << tum_line(kT0 + t, flight_.at(ns_to_s(t)).T_world_body);
      if (t >= s_to_ns(2.0))
        vo << tum_line(kT0 + t, flight_.at(ns_to_s(t)).T_world_body * sim_.T_body_cam);
    }
  }
  const RunResult r = run("fuse --imu " + quoted((dir_ / "imu_first.csv").string()) + " --vo " +
                          quoted((dir_ / "vo_late.txt").string()) + " --calib " +
                          quoted((dir_ / "imu.yaml").string()) + " --init " +
                          quoted((dir_ / "init_long.txt").string()) + " --out " +
                          quoted((dir_ / "fused.txt").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find((dir_ / "imu_first.csv").string() + ": none of its 101 samples"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("before the initial state"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "fused.txt"));
}

TEST_F(CmdFuse, EmptyImuFileIsAnErrorNamingIt) {
  std::ofstream(dir_ / "empty.csv") << "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n";
  const RunResult r =
      run("fuse --imu " + quoted((dir_ / "empty.csv").string()) + " --vo " +
          quoted((dir_ / "vo.txt").string()) + " --calib " + quoted((dir_ / "imu.yaml").string()) +
          " --out " + quoted((dir_ / "fused.txt").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find((dir_ / "empty.csv").string() + ": no IMU samples"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("never held still"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "fused.txt"));
}

// An initial trajectory that starts 3 s into the odometry does not give its first pose.
TEST_F(CmdFuse, InitNotCoveringTheOdometryIsAnError) {
  {
    std::ofstream init(dir_ / "late_init.txt");
    for (TimeNs t = s_to_ns(3.0); t <= s_to_ns(3.1); t += s_to_ns(0.005)) {
      init << tum_line(kT0 + t, flight_.at(ns_to_s(t)).T_world_body);
    }
  }
  const RunResult r =
      run("fuse --imu " + quoted((dir_ / "imu.csv").string()) + " --vo " +
          quoted((dir_ / "vo.txt").string()) + " --calib " + quoted((dir_ / "imu.yaml").string()) +
          " --init " + quoted((dir_ / "late_init.txt").string()) + " --out " +
          quoted((dir_ / "fused.txt").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find((dir_ / "late_init.txt").string() + ": covers"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not the first odometry pose"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "fused.txt"));
  // The same file is fine for odometry that starts inside it.
  const RunResult ok = run(common_args(dir_ / "imu.yaml"));
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
}

// An accelerometer reading 10 g more along x than it should from 1 s on (within the sensor's
// range): the fused speed passes any MAV's, and the run is an error, not exit 0.
TEST_F(CmdFuse, ImplausibleResultIsAnErrorNotExitZero) {
  rewrite_imu(dir_ / "imu.csv", dir_ / "imu_push.csv", [&](std::size_t k, std::string& row) {
    if (k >= 200) {
      std::vector<std::string> f;
      std::istringstream ss(row);
      for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
      f[4] = std::to_string(std::stod(f[4]) + 98.0);
      row.clear();
      for (std::size_t i = 0; i < f.size(); ++i) row += (i ? "," : "") + f[i];
    }
    return true;
  });
  const RunResult r =
      run("fuse --imu " + quoted((dir_ / "imu_push.csv").string()) + " --vo " +
          quoted((dir_ / "vo.txt").string()) + " --calib " + quoted((dir_ / "imu.yaml").string()) +
          " --init " + quoted((dir_ / "init.txt").string()) + " --out " +
          quoted((dir_ / "fused.txt").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("implausible"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("imu_push.csv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "fused.txt"));
}

TEST_F(CmdFuse, MissingCalibrationFieldIsAClearError) {
  const RunResult r = run(common_args(dir_ / "imu_missing.yaml"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("gyroscope_noise_density"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "fused.txt"));
}

TEST_F(CmdFuse, FuseEvalMovesTheGapAndRejectsANegativeStart) {
  const RunResult bad = run("lab fuse-eval --data " + quoted(dir_.string()) + " --gap-start -1");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--gap-start"), std::string::npos) << bad.err;
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth");
  const std::string data = quoted(test::shared_data_dir().string());
  // Two gap positions give two different runs: the option reaches the experiment.
  const RunResult at6 = run("lab fuse-eval --skip-sim --data " + data + " --gap-start 6");
  const RunResult at15 = run("lab fuse-eval --skip-sim --data " + data + " --gap-start 15");
  ASSERT_EQ(at6.exit_code, 0) << at6.err;
  ASSERT_EQ(at15.exit_code, 0) << at15.err;
  auto gap_line = [](const std::string& out) {
    const auto at = out.find("2 s gap:");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  EXPECT_FALSE(gap_line(at6.out).empty()) << at6.out;
  EXPECT_NE(gap_line(at6.out), gap_line(at15.out));
}

// The control experiment is labelled as such and reaches the experiment: the bias reference
// becomes the synthetic IMU's own, and V1_01 (no still start) gets one.
TEST_F(CmdFuse, FuseEvalSyntheticImuIsLabelledAsAControlExperiment) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth");
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const std::string data = quoted(test::shared_data_dir().string());
  const RunResult r = run("lab fuse-eval --skip-sim --vo-keyframes --synthetic-imu --data " + data);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("CONTROL EXPERIMENT"), std::string::npos) << r.out;
  std::size_t n = 0;
  for (auto at = r.out.find("the synthetic IMU's own"); at != std::string::npos;
       at = r.out.find("the synthetic IMU's own", at + 1)) {
    ++n;
  }
  EXPECT_EQ(n, 2u) << r.out;  // V1_02 and V1_01
  const RunResult real = run("lab fuse-eval --skip-sim --vo-keyframes --data " + data);
  ASSERT_EQ(real.exit_code, 0) << real.err;
  EXPECT_EQ(real.out.find("CONTROL EXPERIMENT"), std::string::npos);
}

}  // namespace
}  // namespace kestrel::fusion
