// Motion blur and rolling shutter as resampling along the image flow.
#include "kestrel/sim/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

void image_flow(const PinholeCamera& camera, const cv::Mat& depth_m, const Eigen::Vector3d& v,
                const Eigen::Vector3d& w, cv::Mat& flow) {
  if (depth_m.type() != CV_32F) throw InputError("image_flow: depth must be CV_32F");
  flow.create(depth_m.size(), CV_32FC2);
  // Single precision, branch-free: the compiler vectorises the row loop, and a flow in px/s
  // needs no more than float's 7 digits.
  const auto fx = static_cast<float>(camera.fx()), fy = static_cast<float>(camera.fy());
  const auto cx = static_cast<float>(camera.cx()), cy = static_cast<float>(camera.cy());
  const Eigen::Vector3f vf = v.cast<float>(), wf = w.cast<float>();
  const float inv_fx = 1.0F / fx, inv_fy = 1.0F / fy;
  const float inf = std::numeric_limits<float>::infinity();
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* z = depth_m.ptr<float>(r);
    auto* f = flow.ptr<float>(r);  // interleaved (u, v) pairs
    const float y = (static_cast<float>(r) - cy) * inv_fy;
    for (int c = 0; c < depth_m.cols; ++c) {
      const float x = (static_cast<float>(c) - cx) * inv_fx;
      // No depth (0, negative, infinite or NaN): rho 0, the rotation's part only.
      const float rho = (z[c] > 0.0F && z[c] < inf) ? 1.0F / z[c] : 0.0F;
      // d(x, y)/dt of a static point, camera twist (v, w) in its own frame.
      const float xd =
          -rho * vf.x() + x * rho * vf.z() + x * y * wf.x() - (1.0F + x * x) * wf.y() + y * wf.z();
      const float yd =
          -rho * vf.y() + y * rho * vf.z() + (1.0F + y * y) * wf.x() - x * y * wf.y() - x * wf.z();
      f[2 * c] = fx * xd;
      f[2 * c + 1] = fy * yd;
    }
  }
}

int exposure_taps(const ExposureOptions& o, double max_flow_px_s) {
  if (!(o.exposure_s > 0.0)) return 1;
  const double length_px = max_flow_px_s * o.exposure_s;
  return std::clamp(static_cast<int>(std::ceil(length_px)) + 1, 1, std::max(1, o.max_taps));
}

void expose(const cv::Mat& sharp, const cv::Mat& flow, const ExposureOptions& o, cv::Mat& out) {
  ExposureWorkspace workspace;
  expose(sharp, flow, o, out, workspace);
}

void expose(const cv::Mat& sharp, const cv::Mat& flow, const ExposureOptions& o, cv::Mat& out,
            ExposureWorkspace& ws) {
  if (sharp.channels() != 1 || (sharp.depth() != CV_8U && sharp.depth() != CV_32F)) {
    throw InputError("expose: the image must be one channel, CV_8U or CV_32F");
  }
  if (flow.type() != CV_32FC2 || flow.size() != sharp.size()) {
    throw InputError("expose: the flow must be CV_32FC2 of the image's size");
  }
  if (!o.active()) {
    sharp.copyTo(out);
    return;
  }
  // The largest squared speed, one square root at the end (not one per pixel).
  float max_flow2 = 0.0F;
  for (int r = 0; r < flow.rows; ++r) {
    const auto* f = flow.ptr<cv::Vec2f>(r);
    for (int c = 0; c < flow.cols; ++c) {
      max_flow2 = std::max(max_flow2, f[c][0] * f[c][0] + f[c][1] * f[c][1]);
    }
  }
  const int taps = exposure_taps(o, std::sqrt(static_cast<double>(max_flow2)));
  sharp.convertTo(ws.source, CV_32F);
  ws.sum.create(sharp.size(), CV_32F);
  ws.map_x.create(sharp.size(), CV_32F);
  ws.map_y.create(sharp.size(), CV_32F);
  const double row_time = o.readout_s / sharp.rows;
  const double middle = 0.5 * (sharp.rows - 1);
  for (int k = 0; k < taps; ++k) {
    // Midpoints of `taps` equal parts of the exposure, centred on the row's mid-exposure.
    const double tau = o.exposure_s * ((k + 0.5) / taps - 0.5);
    for (int r = 0; r < sharp.rows; ++r) {
      // Single precision (vectorised): offsets of a few pixels, positions below 2^24.
      const auto dt = static_cast<float>((r - middle) * row_time + tau);
      const auto* f = flow.ptr<float>(r);  // interleaved (u, v) pairs
      float* mx = ws.map_x.ptr<float>(r);
      float* my = ws.map_y.ptr<float>(r);
      const auto row = static_cast<float>(r);
      for (int c = 0; c < sharp.cols; ++c) {
        mx[c] = static_cast<float>(c) - f[2 * c] * dt;
        my[c] = row - f[2 * c + 1] * dt;
      }
    }
    // The first tap's samples are the sum so far: no zeroing pass.
    cv::remap(ws.source, k == 0 ? ws.sum : ws.sample, ws.map_x, ws.map_y, cv::INTER_LINEAR,
              cv::BORDER_REPLICATE);
    if (k > 0) ws.sum += ws.sample;
  }
  ws.sum.convertTo(out, sharp.depth(), 1.0 / taps);
}

}  // namespace kestrel::sim
