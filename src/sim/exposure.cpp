// Motion blur and rolling shutter as resampling along the image flow.
#include "kestrel/sim/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

void image_flow(const PinholeCamera& camera, const cv::Mat& depth_m, const Eigen::Vector3d& v,
                const Eigen::Vector3d& w, cv::Mat& flow) {
  if (depth_m.type() != CV_32F) throw InputError("image_flow: depth must be CV_32F");
  flow.create(depth_m.size(), CV_32FC2);
  const double fx = camera.fx(), fy = camera.fy(), cx = camera.cx(), cy = camera.cy();
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* z = depth_m.ptr<float>(r);
    auto* f = flow.ptr<cv::Vec2f>(r);
    const double y = (r - cy) / fy;
    for (int c = 0; c < depth_m.cols; ++c) {
      const double x = (c - cx) / fx;
      const double rho =
          (std::isfinite(z[c]) && z[c] > 0.0F) ? 1.0 / static_cast<double>(z[c]) : 0.0;
      // d(x, y)/dt of a static point, camera twist (v, w) in its own frame.
      const double xd =
          -rho * v.x() + x * rho * v.z() + x * y * w.x() - (1.0 + x * x) * w.y() + y * w.z();
      const double yd =
          -rho * v.y() + y * rho * v.z() + (1.0 + y * y) * w.x() - x * y * w.y() - x * w.z();
      f[c] = cv::Vec2f(static_cast<float>(fx * xd), static_cast<float>(fy * yd));
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
      const double dt = (r - middle) * row_time + tau;
      const auto* f = flow.ptr<cv::Vec2f>(r);
      float* mx = ws.map_x.ptr<float>(r);
      float* my = ws.map_y.ptr<float>(r);
      for (int c = 0; c < sharp.cols; ++c) {
        mx[c] = static_cast<float>(c - static_cast<double>(f[c][0]) * dt);
        my[c] = static_cast<float>(r - static_cast<double>(f[c][1]) * dt);
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
