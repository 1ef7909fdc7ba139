// Exposure effects of a moving camera, applied to the sharp, global-shutter image rendered at
// the frame's reference time t0 (the middle row's mid-exposure): motion blur (each pixel
// integrates the scene over the exposure) and rolling-shutter readout (row v is exposed
// (v - (H - 1) / 2) * readout_s / H later than the middle row). Both come from the image
// motion of a static scene under the camera's twist (the interaction matrix of a point,
// Chaumette & Hutchinson 2006 eq. 11), to first order in time: the image at t0 + dt is
// I(p - flow(p) dt), so the exposed image is the mean of that over the row's exposure window,
// taken at `taps` instants (bilinear resampling). A cheap stand-in for rendering sub-exposure
// poses: no occlusion changes and a flow that is constant over the window; exact for a
// fronto-parallel plane under translation.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "kestrel/geometry/pinhole_camera.hpp"

namespace kestrel::sim {

struct ExposureOptions {
  double exposure_s = 0.0;  ///< 0: no motion blur
  double readout_s = 0.0;   ///< first to last row; 0: global shutter
  /// Samples over each exposure; the number used is the blur length in pixels + 1, up to this.
  int max_taps = 5;
  [[nodiscard]] bool active() const { return exposure_s > 0.0 || readout_s > 0.0; }
};

/// Image motion (px/s, CV_32FC2) of a static scene seen by a camera moving with linear
/// velocity v_cam and angular velocity w_cam (both in the camera frame: x right, y down,
/// z forward), depth_m the scene's Z per pixel (CV_32F; 0 or non-finite: no depth, the
/// rotation's part only).
void image_flow(const PinholeCamera& camera, const cv::Mat& depth_m, const Eigen::Vector3d& v_cam,
                const Eigen::Vector3d& w_cam, cv::Mat& flow);

/// Scratch images of expose(): kept by a caller that exposes every frame, so that a frame of
/// the same size allocates nothing.
struct ExposureWorkspace {
  cv::Mat source, sum, map_x, map_y, sample;
};

/// The exposed image (same type as `sharp`: CV_8U or CV_32F, one channel) from the sharp one
/// and its flow.
void expose(const cv::Mat& sharp, const cv::Mat& flow, const ExposureOptions& options,
            cv::Mat& out);
/// The same with the caller's scratch images.
void expose(const cv::Mat& sharp, const cv::Mat& flow, const ExposureOptions& options, cv::Mat& out,
            ExposureWorkspace& workspace);

/// The number of samples expose() takes over one exposure for a largest flow (px/s).
int exposure_taps(const ExposureOptions& options, double max_flow_px_s);

}  // namespace kestrel::sim
