// The world's disturbance models against their specifications: Dryden gusts (variance,
// autocorrelation), dropped frames, latency jitter, motion blur's kernel length, the rolling
// shutter's row time, the image flow; the vehicle mismatch, wind drag, the IMU drift; the
// world YAML.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numeric>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/sim/camera_link.hpp"
#include "kestrel/sim/exposure.hpp"
#include "kestrel/sim/vehicle_imu.hpp"
#include "kestrel/sim/wind.hpp"
#include "kestrel/sim/world.hpp"

namespace kestrel::sim {
namespace {

// Sample variance and normalised autocorrelation at a lag (in samples) of a zero-mean series.
double variance(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v * v;
  return s / static_cast<double>(x.size());
}
double autocorrelation(const std::vector<double>& x, std::size_t lag) {
  double s = 0.0;
  for (std::size_t i = lag; i < x.size(); ++i) s += x[i] * x[i - lag];
  return s / static_cast<double>(x.size() - lag) / variance(x);
}

std::vector<double> run_component(bool second_order, double T, double dt, std::size_t n,
                                  std::uint64_t seed) {
  DrydenComponent c(second_order);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> x(n);
  for (std::size_t i = 0; i < 20000; ++i) c.step(dt, T, normal(rng));  // 20 T of warm-up
  for (double& v : x) v = c.step(dt, T, normal(rng));
  return x;
}

// 20000 correlation times: the variance's standard error is ~1.4 %, an autocorrelation's ~0.01.
TEST(Dryden, FirstOrderGustHasUnitVarianceAndExponentialCorrelation) {
  const double T = 1.0, dt = 1e-3;
  const auto x = run_component(false, T, dt, 20'000'000, 3);
  EXPECT_NEAR(variance(x), 1.0, 0.06);
  for (double tau : {0.25, 1.0, 2.0}) {
    EXPECT_NEAR(autocorrelation(x, static_cast<std::size_t>(tau / dt)), std::exp(-tau / T), 0.03)
        << "tau=" << tau;
  }
}

TEST(Dryden, SecondOrderGustMatchesTheDrydenAutocorrelation) {
  const double T = 1.0, dt = 1e-3;
  const auto x = run_component(true, T, dt, 20'000'000, 4);
  EXPECT_NEAR(variance(x), 1.0, 0.06);
  for (double tau : {0.25, 1.0, 2.0, 3.0}) {
    // MIL-F-8785C: R(tau) = sigma^2 (1 - tau V / (2 L)) exp(-tau V / L); negative past 2 L / V.
    const double expected = (1.0 - tau / (2.0 * T)) * std::exp(-tau / T);
    EXPECT_NEAR(autocorrelation(x, static_cast<std::size_t>(tau / dt)), expected, 0.03)
        << "tau=" << tau;
  }
}

TEST(Dryden, LowAltitudeScalesAtTenFeet) {
  // MIL-F-8785C at h = 10 ft: L_u = 10 / 0.18523^1.2 ft = 75.64 ft = 23.05 m, L_w = 10 ft,
  // sigma_u / sigma_w = 1 / 0.18523^0.4 = 1.963, sigma_w = 0.1 W20.
  const DrydenScales s = dryden_low_altitude(3.048, 10.0);
  EXPECT_NEAR(s.length_m.x(), 23.05, 0.02);
  EXPECT_NEAR(s.length_m.y(), 23.05, 0.02);
  EXPECT_NEAR(s.length_m.z(), 3.048, 1e-9);
  EXPECT_NEAR(s.sigma_m_s.z(), 1.0, 1e-12);
  EXPECT_NEAR(s.sigma_m_s.x(), 1.963, 0.001);
}

TEST(Dryden, WindModelGustsHaveTheDrydenIntensitiesAlongTheMeanWind) {
  WindOptions o;
  o.mean_world_m_s = Eigen::Vector3d(0.0, 15.0, 0.0);  // u along +y: T_u = 23 / 15 = 1.5 s
  o.turbulence_w20_m_s = 5.0;
  WindModel wind(o, 7);
  const DrydenScales s = dryden_low_altitude(3.048, 5.0);
  std::vector<double> u, v, w;
  const Eigen::Vector3d p(0.0, 0.0, 1.0), still = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3'000'000; ++i) {  // 3000 s: 2000 T_u; variance error ~3 %
    const Eigen::Vector3d air = wind.step(1e-3, p, still) - o.mean_world_m_s;
    u.push_back(air.y());
    v.push_back(-air.x());
    w.push_back(air.z());
  }
  EXPECT_NEAR(std::sqrt(variance(u)), s.sigma_m_s.x(), 0.08 * s.sigma_m_s.x());
  EXPECT_NEAR(std::sqrt(variance(v)), s.sigma_m_s.y(), 0.08 * s.sigma_m_s.y());
  EXPECT_NEAR(std::sqrt(variance(w)), s.sigma_m_s.z(), 0.08 * s.sigma_m_s.z());
  // Correlation time L_u / V of the longitudinal gust.
  const double T_u = s.length_m.x() / 15.0;
  EXPECT_NEAR(autocorrelation(u, static_cast<std::size_t>(T_u / 1e-3)), std::exp(-1.0), 0.05);
}

TEST(CameraLink, DropsTheConfiguredShareOfFrames) {
  CameraLink link(0.05, 0.0, 11);
  int dropped = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) dropped += link.drop() ? 1 : 0;
  // Binomial standard error sqrt(0.05 * 0.95 / n) = 0.0007.
  EXPECT_NEAR(dropped / static_cast<double>(n), 0.05, 0.0035);
  CameraLink none(0.0, 0.0, 11);
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(none.drop());
}

TEST(CameraLink, LatencyJitterStaysWithinItsBoundsAndIsUniform) {
  CameraLink link(0.0, 0.010, 12);
  std::vector<double> l(100000);
  for (double& v : l) v = link.latency_s(0.040);
  const auto [lo, hi] = std::minmax_element(l.begin(), l.end());
  EXPECT_GE(*lo, 0.030);
  EXPECT_LE(*hi, 0.050);
  EXPECT_LT(*lo, 0.0301);
  EXPECT_GT(*hi, 0.0499);
  const double mean = std::accumulate(l.begin(), l.end(), 0.0) / l.size();
  double var = 0.0;
  for (double v : l) var += (v - mean) * (v - mean);
  EXPECT_NEAR(mean, 0.040, 1e-4);
  EXPECT_NEAR(std::sqrt(var / l.size()), 0.020 / std::sqrt(12.0), 1e-4);  // uniform's std
}

TEST(CameraLink, RejectsBadParameters) {
  EXPECT_THROW(CameraLink(1.0, 0.0, 1), InputError);
  EXPECT_THROW(CameraLink(-0.1, 0.0, 1), InputError);
  EXPECT_THROW(CameraLink(0.1, -0.01, 1), InputError);
}

// A vertical step edge at column 100: 0 left, 200 right.
cv::Mat edge_image() {
  cv::Mat img(240, 376, CV_32F, cv::Scalar(0.0F));
  img.colRange(100, img.cols).setTo(200.0F);
  return img;
}

// Sub-pixel column where row r of a left-to-right rising edge crosses `level`.
double crossing(const cv::Mat& img, int r, double level) {
  const float* q = img.ptr<float>(r);
  for (int c = 1; c < img.cols; ++c) {
    const double a = q[c - 1], b = q[c];
    if (a < level && b >= level) return c - 1 + (level - a) / (b - a);
  }
  return -1.0;
}

TEST(Exposure, BlurKernelLengthIsTheImageMotionDuringTheExposure) {
  const cv::Mat sharp = edge_image();
  cv::Mat flow(sharp.size(), CV_32FC2, cv::Scalar(500.0F, 0.0F));  // 500 px/s to the right
  ExposureOptions o;
  o.exposure_s = 0.020;  // 10 px of motion
  o.max_taps = 64;
  cv::Mat out;
  expose(sharp, flow, o, out);
  EXPECT_EQ(exposure_taps(o, 500.0), 11);
  // A box kernel of length L turns the step into a linear ramp: 10 %-90 % width 0.8 L.
  const double width = crossing(out, 120, 180.0) - crossing(out, 120, 20.0);
  EXPECT_NEAR(width / 0.8, 10.0, 1.0);
  // Centred on the mid-exposure: the 50 % crossing stays at the edge (99.5 between pixels).
  EXPECT_NEAR(crossing(out, 120, 100.0), 99.5, 0.3);
  // No motion: no blur.
  expose(sharp, cv::Mat(sharp.size(), CV_32FC2, cv::Scalar(0.0F, 0.0F)), o, out);
  EXPECT_NEAR(crossing(out, 120, 180.0) - crossing(out, 120, 20.0), 0.8, 0.05);
}

TEST(Exposure, RollingShutterShiftsEachRowByItsReadoutTime) {
  const cv::Mat sharp = edge_image();
  cv::Mat flow(sharp.size(), CV_32FC2, cv::Scalar(500.0F, 0.0F));
  ExposureOptions o;
  o.readout_s = 0.024;  // row time 0.1 ms
  cv::Mat out;
  expose(sharp, flow, o, out);
  const double row_time = o.readout_s / sharp.rows;
  for (int r : {0, 60, 180, 239}) {
    // Row r is read (r - 119.5) row times after the middle; the edge moves with the flow.
    const double expected = 99.5 + 500.0 * (r - 119.5) * row_time;
    EXPECT_NEAR(crossing(out, r, 100.0), expected, 0.1) << "row " << r;
  }
}

TEST(Exposure, ImageFlowIsTheProjectedMotionOfAStaticPoint) {
  const PinholeCamera camera(PinholeIntrinsics{250.0, 250.0, 187.5, 119.5, 376, 240});
  const Eigen::Vector3d v(0.4, -0.2, 0.7), w(0.3, -0.5, 0.8);
  const double dt = 1e-6;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.3, -0.2, 2.0), Eigen::Vector3d(-0.6, 0.4, 1.3)}) {
    const Eigen::Vector2d uv = camera.project(p);
    cv::Mat depth(240, 376, CV_32F, cv::Scalar(0.0F));
    const int c = static_cast<int>(std::lround(uv.x())), r = static_cast<int>(std::lround(uv.y()));
    // Evaluate at the exact pixel: move the point to the pixel centre's ray.
    const Eigen::Vector3d q = camera.unproject(Eigen::Vector2d(c, r), p.z());
    depth.at<float>(r, c) = static_cast<float>(q.z());
    cv::Mat flow;
    image_flow(camera, depth, v, w, flow);
    // A static point in the moving camera's frame: dq/dt = -v - w x q.
    const Eigen::Vector3d q2 = q + dt * (-v - w.cross(q));
    const Eigen::Vector2d expected = (camera.project(q2) - camera.project(q)) / dt;
    const cv::Vec2f f = flow.at<cv::Vec2f>(r, c);
    EXPECT_NEAR(f[0], expected.x(), 1e-3 * expected.norm() + 1e-3);
    EXPECT_NEAR(f[1], expected.y(), 1e-3 * expected.norm() + 1e-3);
  }
}

TEST(VehicleMismatch, TrueVehicleScalesTheNominalOne) {
  const WorldOptions w = WorldOptions::realistic();
  const QuadrotorParameters nominal;
  const QuadrotorParameters truth = w.vehicle_mismatch.true_vehicle(nominal);
  EXPECT_DOUBLE_EQ(truth.mass_kg, 1.15 * nominal.mass_kg);
  EXPECT_DOUBLE_EQ(truth.thrust_coefficient, 0.90 * nominal.thrust_coefficient);
  EXPECT_DOUBLE_EQ(truth.motor_time_constant_s, 1.5 * nominal.motor_time_constant_s);
  EXPECT_TRUE(truth.center_of_mass_offset_m.isApprox(w.vehicle_mismatch.center_of_mass_offset_m));
  // The nominal hover speed no longer carries the true vehicle: 1.15 / 0.9 = 1.28 x the thrust.
  EXPECT_NEAR(truth.hover_rotor_speed_rad_s() / nominal.hover_rotor_speed_rad_s(),
              std::sqrt(1.15 / 0.9), 1e-12);
}

TEST(Quadrotor, DragActsOnTheAirRelativeVelocity) {
  QuadrotorParameters p;
  Quadrotor q(p, Quadrotor::hover_state(p, Eigen::Vector3d(0, 0, 2)));
  q.set_wind_world(Eigen::Vector3d(2.0, 0.0, 0.0));
  q.step(1e-3, Eigen::Vector4d::Constant(p.hover_rotor_speed_rad_s()));
  // At rest in a 2 m/s wind: F = (c1 2 + c2 4) along the wind.
  const double expected =
      (p.linear_drag_N_s_m.x() * 2.0 + p.quadratic_drag_N_s2_m2.x() * 4.0) / p.mass_kg;
  EXPECT_NEAR(q.state().a_world.x(), expected, 0.01 * expected);
  EXPECT_NEAR(q.state().a_world.y(), 0.0, 1e-6);
}

TEST(Quadrotor, CentreOfMassOffsetTiltsAtEqualRotorSpeeds) {
  QuadrotorParameters p;
  p.center_of_mass_offset_m = Eigen::Vector3d(0.01, 0.0, 0.0);
  Quadrotor q(p, Quadrotor::hover_state(p, Eigen::Vector3d(0, 0, 2)));
  q.step(1e-3, Eigen::Vector4d::Constant(p.hover_rotor_speed_rad_s()));
  // tau_y = sum -(x_i - c_x) f_i = c_x T at equal thrusts (T = m g).
  const double expected = 0.01 * p.mass_kg * p.gravity_m_s2 / p.inertia_kg_m2.y();
  EXPECT_NEAR(q.state().alpha_body.y(), expected, 0.02 * expected);
  EXPECT_NEAR(q.state().alpha_body.x(), 0.0, 1e-6);
}

TEST(VehicleImu, WarmUpDriftFollowsItsTimeConstant) {
  io::ImuNoise n = default_vehicle_imu_noise();
  n.gyro_noise_density = n.accel_noise_density = n.gyro_random_walk = n.accel_random_walk = 0.0;
  VehicleImuSimulator imu(n, 5, 0.0, 0.0);
  imu.set_warm_up_drift(2e-3, 0.05, 10.0);
  QuadrotorState s = Quadrotor::hover_state(QuadrotorParameters{}, Eigen::Vector3d(0, 0, 1));
  const io::ImuSample first = imu.sample(s);
  EXPECT_NEAR((first.gyro_rad_s - imu.ideal_sample(s).gyro_rad_s).norm(), 0.0, 1e-12);
  s.t_ns = s_to_ns(10.0);
  const io::ImuSample later = imu.sample(s);
  const double k = 1.0 - std::exp(-1.0);
  EXPECT_NEAR((later.gyro_rad_s - imu.ideal_sample(s).gyro_rad_s).norm(), k * 2e-3, 1e-9);
  EXPECT_NEAR((later.accel_m_s2 - imu.ideal_sample(s).accel_m_s2).norm(), k * 0.05, 1e-9);
}

std::filesystem::path write_temp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path;
}

TEST(WorldOptions, DocumentedYamlRoundTrips) {
  for (const WorldOptions& w : {WorldOptions::ideal(), WorldOptions::realistic()}) {
    const std::string text = w.to_documented_yaml();
    EXPECT_NE(text.find("white_noise_scale: "), std::string::npos);
    EXPECT_NE(text.find("# x the data-sheet white-noise densities"), std::string::npos) << text;
    const auto path = write_temp("kestrel_world_" + w.name + ".yaml", text);
    const WorldOptions back = WorldOptions::load(path);
    EXPECT_EQ(io::option_fields::to_yaml(back), io::option_fields::to_yaml(w));
    std::filesystem::remove(path);
  }
  // Every field has its comment.
  const std::string text = WorldOptions::realistic().to_documented_yaml();
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    EXPECT_NE(line.find(" # "), std::string::npos) << line;
  }
  EXPECT_EQ(WorldOptions::from_argument("realistic").name, "realistic");
  EXPECT_EQ(WorldOptions::from_argument("ideal").camera.drop_probability, 0.0);
}

TEST(WorldOptions, BadInputNamesTheFileAndField) {
  auto message = [](const std::string& yaml) {
    const auto path = write_temp("kestrel_world_bad.yaml", yaml);
    try {
      (void)WorldOptions::load(path);
    } catch (const InputError& e) {
      std::filesystem::remove(path);
      return std::string(e.what());
    }
    std::filesystem::remove(path);
    return std::string("no error");
  };
  std::string m = message("imu:\n  white_noise_scale: -1\n");
  EXPECT_NE(m.find("kestrel_world_bad.yaml"), std::string::npos) << m;
  EXPECT_NE(m.find("imu.white_noise_scale"), std::string::npos) << m;
  m = message("wind:\n  gusts: 1\n");
  EXPECT_NE(m.find("wind.gusts"), std::string::npos) << m;
  EXPECT_NE(m.find("kestrel_world_bad.yaml"), std::string::npos) << m;
  m = message("camera:\n  drop_probability: 1.5\n");
  EXPECT_NE(m.find("camera.drop_probability"), std::string::npos) << m;
  m = message("world:\n  vehicle_mismatch:\n    mass_scale: abc\n");
  EXPECT_NE(m.find("vehicle_mismatch.mass_scale"), std::string::npos) << m;
  EXPECT_THROW((void)WorldOptions::from_argument("no_such_world.yaml"), InputError);
}

}  // namespace
}  // namespace kestrel::sim
