// The inner loop of the direct tracker with a run-time backend: warp + bilinear sample +
// residual of every reference point, then Tukey weights, robust cost, inliers and the 8x8
// normal equations (thesis 3.7-3.8). The CPU path calls the tracker's own kernels
// (odometry/alignment_kernels.hpp: AVX2 where compiled for it); the CUDA path runs the functions
// of device/photometric.hpp with a block reduction. docs/gpu.md states the tolerances.
#pragma once

#include <cstdint>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/gpu/backend.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"

namespace kestrel::gpu {

/// The weighted normal equations of one iteration (photometric residuals only).
struct NormalEquations {
  odometry::Matrix8d H = odometry::Matrix8d::Zero();  ///< sum w J J^T
  odometry::Vector8d g = odometry::Vector8d::Zero();  ///< sum w J r
  double cost = 0.0;  ///< sum of Tukey costs; points outside the image cost c^2/6
  int inliers = 0;    ///< valid residuals with |r / sigma| < c
};

class PhotometricStep {
 public:
  /// Throws BackendUnavailable for kCuda without a device.
  explicit PhotometricStep(Backend backend = Backend::kAuto, std::ostream* notice = &std::cerr);
  ~PhotometricStep();
  PhotometricStep(const PhotometricStep&) = delete;
  PhotometricStep& operator=(const PhotometricStep&) = delete;

  /// The reference points of one level and their Jacobians (once per keyframe and level).
  void set_reference(const odometry::ReferenceLevel& level);
  /// The current image of the same level (CV_32FC1, at least 2x2).
  void set_image(const cv::Mat& current);
  /// Residuals r = alpha I_cur(pi(T_cur_ref P)) + beta - I_ref of every reference point; returns
  /// how many land inside the image (the others have r = 0 and are not valid).
  int warp(const SE3& T_cur_ref, float alpha, float beta);
  /// The residuals and validity of the last warp, in point order.
  void residuals(std::vector<float>& r, std::vector<std::uint8_t>& valid);
  /// |r| of the valid residuals of the last warp (for the robust sigma), in point order.
  void valid_abs_residuals(std::vector<float>& out);
  /// Weights w = tukey_weight(r / sigma, c) / sigma^2 and the normal equations of the last warp.
  NormalEquations normal_equations(float inv_sigma, float tukey_c);

  [[nodiscard]] Backend backend() const { return backend_; }
  [[nodiscard]] int points() const { return count_; }
  [[nodiscard]] const StageTiming& last_timing() const { return timing_; }

  class Engine {
   public:
    virtual ~Engine() = default;
    virtual void set_reference(const odometry::ReferenceLevel& level, StageTiming& timing) = 0;
    virtual void set_image(const cv::Mat& current, StageTiming& timing) = 0;
    virtual int warp(const float R[9], const float t[3], float alpha, float beta,
                     StageTiming& timing) = 0;
    virtual void residuals(std::vector<float>& r, std::vector<std::uint8_t>& valid,
                           StageTiming& timing) = 0;
    virtual NormalEquations normal_equations(float inv_sigma, float tukey_c,
                                             StageTiming& timing) = 0;
  };

 private:
  Backend backend_;
  std::unique_ptr<Engine> cuda_;
  int count_ = 0;
  // CPU path: the reference level (copied) and the tracker's per-iteration buffers.
  odometry::ReferenceLevel ref_;
  cv::Mat image_;
  std::vector<float> residual_;
  std::vector<std::uint8_t> valid_;
  std::vector<float> weight_;
  std::vector<float> scratch_r_;
  std::vector<std::uint8_t> scratch_v_;
  StageTiming timing_;
};

}  // namespace kestrel::gpu
