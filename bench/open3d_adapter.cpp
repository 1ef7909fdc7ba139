// Open3D's RGB-D odometry (ComputeRGBDOdometry with Open3D's defaults: the hybrid photometric +
// geometric Jacobian, OdometryOption) between consecutive frames; see open3d_adapter.hpp for
// why this file is compiled apart.
#include "open3d_adapter.hpp"

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/pipelines/odometry/Odometry.h>
#include <open3d/utility/Logging.h>

#include <cstring>

namespace kestrel::peer {

namespace o3d = open3d;

struct Open3dOdometry::State {
  o3d::camera::PinholeCameraIntrinsic intrinsic;
  std::shared_ptr<o3d::geometry::RGBDImage> prev;
};

Open3dOdometry::Open3dOdometry(const Open3dIntrinsics& k) : state_(std::make_unique<State>()) {
  o3d::utility::SetVerbosityLevel(o3d::utility::VerbosityLevel::Error);
  state_->intrinsic.SetIntrinsics(k.width, k.height, k.fx, k.fy, k.cx, k.cy);
}

Open3dOdometry::~Open3dOdometry() = default;

bool Open3dOdometry::add_frame(const std::uint8_t* rgb, const float* depth_m,
                               double T_cur_prev[16]) {
  const int w = state_->intrinsic.width_;
  const int h = state_->intrinsic.height_;
  o3d::geometry::Image color, depth;
  color.Prepare(w, h, 3, 1);
  std::memcpy(color.data_.data(), rgb, color.data_.size());
  depth.Prepare(w, h, 1, 4);
  std::memcpy(depth.data_.data(), depth_m, depth.data_.size());
  // Depth in metres (scale 1), truncated at 4 m as Open3D's TUM loader does; colour turned into
  // intensity.
  auto cur = o3d::geometry::RGBDImage::CreateFromColorAndDepth(color, depth, 1.0, 4.0, true);
  bool ok = false;
  if (state_->prev) {
    // The motion maps points of the source (previous) frame into the target (current) one.
    const auto result =
        o3d::pipelines::odometry::ComputeRGBDOdometry(*state_->prev, *cur, state_->intrinsic);
    ok = std::get<0>(result);
    const Eigen::Matrix4d& T = std::get<1>(result);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T_cur_prev[4 * r + c] = T(r, c);
    }
  }
  state_->prev = cur;
  return ok;
}

}  // namespace kestrel::peer
