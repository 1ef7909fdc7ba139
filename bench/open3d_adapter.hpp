// Open3D's RGB-D odometry behind an interface without Eigen types. Debian's Open3D is built
// for the baseline x86-64 ABI, where Eigen's fixed-size matrices are 16-byte aligned; Kestrel's
// release build at -march=native aligns them to 32 bytes, so Eigen values must not cross
// between the two (a returned Matrix4d comes back as garbage). open3d_adapter.cpp is therefore
// compiled without Kestrel's CPU flags and only plain arrays pass this line.
#pragma once

#include <cstdint>
#include <memory>

namespace kestrel::peer {

struct Open3dIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

class Open3dOdometry {
 public:
  explicit Open3dOdometry(const Open3dIntrinsics& intrinsics);
  ~Open3dOdometry();
  Open3dOdometry(const Open3dOdometry&) = delete;
  Open3dOdometry& operator=(const Open3dOdometry&) = delete;

  /// Makes this frame (RGB 8-bit, row-major, `width * 3` bytes a row; depth float metres, 0 =
  /// none) the current one. When a previous frame exists, aligns it to this one and writes the
  /// motion that maps previous-frame points into this frame, row-major, to T_cur_prev; returns
  /// whether Open3D reports success (false for the first frame).
  bool add_frame(const std::uint8_t* rgb, const float* depth_m, double T_cur_prev[16]);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace kestrel::peer
