// EuRoC MAV (ASL) folders: mav0/cam0, mav0/cam1 (images + data.csv + sensor.yaml), mav0/imu0
// (data.csv + sensor.yaml) and ground truth CSVs. The index is read at construction; images
// are decoded on request and IMU samples are streamed line by line.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/text_lines.hpp"
#include "kestrel/io/tum_rgbd.hpp"

namespace kestrel::io {

struct ImuSample {
  TimeNs t_ns = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

/// Noise model of an IMU from an EuRoC imu0/sensor.yaml (continuous-time densities).
struct ImuNoise {
  double gyro_noise_density = 0.0;   ///< rad/s/sqrt(Hz)
  double gyro_random_walk = 0.0;     ///< rad/s^2/sqrt(Hz)
  double accel_noise_density = 0.0;  ///< m/s^2/sqrt(Hz)
  double accel_random_walk = 0.0;    ///< m/s^3/sqrt(Hz)
  double rate_hz = 0.0;
  SE3 T_body_imu;  ///< EuRoC T_BS (identity for the EuRoC IMU, which defines the body)
  /// Full scale per axis, where the file gives it (`accelerometer_range_m_s2`,
  /// `gyroscope_range_rad_s`; not EuRoC fields, so usually absent).
  std::optional<double> accel_range_m_s2;
  std::optional<double> gyro_range_rad_s;
  /// `in_flight_noise_inflation` (not an EuRoC field): the factor on the white-noise densities
  /// for in-flight use (fusion::kInFlightImuNoiseInflation where absent).
  std::optional<double> in_flight_noise_inflation;
};

/// Loads an EuRoC IMU sensor.yaml; a missing field is an InputError naming it.
ImuNoise load_imu_noise(const std::filesystem::path& sensor_yaml);

/// Streams an EuRoC IMU CSV: "timestamp [ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]".
class ImuCsvReader {
 public:
  explicit ImuCsvReader(const std::filesystem::path& csv);
  /// The next sample; false at the end. Throws InputError "FILE:LINE: ..." on a malformed
  /// line, a non-finite value, or a time stamp that does not increase.
  bool next(ImuSample& sample);
  /// The file's line of the last sample returned (1-based), for messages about it.
  [[nodiscard]] std::size_t line_number() const { return reader_.line_number(); }

 private:
  TextLineReader reader_;
  std::optional<TimeNs> last_t_ns_;
};

/// One row of an EuRoC state ground truth (state_groundtruth_estimate0 / gt0 data.csv).
struct GroundTruthState {
  TimeNs t_ns = 0;
  SE3 T_world_body;
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};
/// Reads the full-state ground truth (17 columns). Errors name file and line.
std::vector<GroundTruthState> read_euroc_state_groundtruth(const std::filesystem::path& csv);

/// Reads a camera data.csv ("timestamp [ns],filename") as absolute paths under data/.
std::vector<TimedFile> read_euroc_camera_csv(const std::filesystem::path& csv);

struct StereoImages {
  TimeNs t_ns = 0;
  cv::Mat left;   ///< cam0, CV_8UC1
  cv::Mat right;  ///< cam1, CV_8UC1
};

class EurocSequence {
 public:
  /// `folder` is either the sequence folder (holding mav0/) or mav0 itself.
  explicit EurocSequence(const std::filesystem::path& folder);

  [[nodiscard]] const std::filesystem::path& mav0() const { return mav0_; }
  /// Stereo pairs: cam0 and cam1 frames with identical time stamps.
  [[nodiscard]] std::size_t stereo_size() const { return pairs_.size(); }
  [[nodiscard]] TimeNs stereo_timestamp(std::size_t i) const { return cam0_[pairs_[i].first].t_ns; }
  [[nodiscard]] StereoImages load_stereo(std::size_t i) const;
  [[nodiscard]] const std::vector<TimedFile>& cam0_frames() const { return cam0_; }
  /// Decodes one grayscale image of cam0's list; errors name the file.
  [[nodiscard]] cv::Mat load_cam0(std::size_t i) const;

  [[nodiscard]] CameraFile cam0_calibration() const;
  [[nodiscard]] CameraFile cam1_calibration() const;
  [[nodiscard]] bool has_imu() const;
  [[nodiscard]] std::filesystem::path imu_csv() const { return mav0_ / "imu0" / "data.csv"; }
  [[nodiscard]] ImuNoise imu_noise() const {
    return load_imu_noise(mav0_ / "imu0" / "sensor.yaml");
  }
  /// The first ground-truth CSV found among groundtruth_cam0/, state_groundtruth_estimate0/,
  /// gt0/, leica0/ (in that order), or nullopt.
  [[nodiscard]] std::optional<std::filesystem::path> groundtruth_csv() const;

 private:
  std::filesystem::path mav0_;
  std::vector<TimedFile> cam0_;
  std::vector<TimedFile> cam1_;
  std::vector<std::pair<std::size_t, std::size_t>> pairs_;
};

/// Decodes an 8-bit grayscale image; throws InputError naming the file.
cv::Mat read_gray_image(const std::filesystem::path& file);

}  // namespace kestrel::io
