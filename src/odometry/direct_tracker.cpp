// DirectTracker: inverse-compositional alignment over SE(3) + gain/bias (thesis 3.5-3.10),
// with keyframes and a constant-velocity prior (thesis 5.2). See warp_jacobian.hpp for the
// model, its Jacobian and the IC update.
#include "kestrel/odometry/direct_tracker.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <type_traits>

#include "kestrel/core/error.hpp"
#include "kestrel/image/gradient.hpp"
#include "kestrel/image/intensity.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/image/rolling_shutter.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"
#include "kestrel/odometry/disparity_space.hpp"
#include "kestrel/odometry/level_solver.hpp"
#include "kestrel/odometry/point_selection.hpp"
#include "kestrel/odometry/residual_terms.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"

namespace kestrel::odometry {

std::string_view to_string(TrackFailure failure) {
  switch (failure) {
    case TrackFailure::kNone:
      return "none";
    case TrackFailure::kInvalidInput:
      return "invalid_input";
    case TrackFailure::kTooFewPoints:
      return "too_few_points";
    case TrackFailure::kNoOverlap:
      return "no_overlap";
    case TrackFailure::kHighResidual:
      return "high_residual";
    case TrackFailure::kLowInlierRatio:
      return "low_inlier_ratio";
    case TrackFailure::kImplausibleMotion:
      return "implausible_motion";
    case TrackFailure::kNumerical:
      return "numerical";
  }
  return "unknown";
}

namespace {

using kernels::pad_to_lanes;

double rotation_angle_deg(const SE3& T) { return T.so3().log().norm() * 180.0 / std::numbers::pi; }

// How the current image is sampled on the finest level (bicubic_finest_level); the coarser
// levels are sampled bilinearly (docs/odometry.md, "Bicubic on the coarser levels too").
image::Interpolation level_sampling(const DirectTrackerOptions& o, bool finest) {
  return finest && o.solver.bicubic_finest_level ? image::Interpolation::kBicubic
                                                 : image::Interpolation::kBilinear;
}

// The geometric fallback's candidates by normal direction: 5 x 5 bins over the normal's x and y
// (TrackerAccess::bin_normals).
constexpr int kNormalBins = 5;
using NormalBins = std::array<std::vector<int>, kNormalBins * kNormalBins>;

}  // namespace

struct DirectTracker::Impl {
  image::Undistorter undistorter;
  std::vector<PinholeCamera> level_cameras;

  // Current frame (reused buffers). Its intensity and depth are written straight into the
  // pyramids' level 0 (IntensityPyramid::base, DepthPyramid::base): no copy of either.
  cv::Mat intensity_raw;
  image::IntensityPyramid pyramid;
  // The previous frame's (swapped, not copied): the fallback reference after a failure.
  image::IntensityPyramid prev_pyramid;
  image::DepthPyramid prev_depth_pyramid;

  // Reference (keyframe) data.
  std::vector<ReferenceLevel> ref;
  // The current frame's reference data, for the fallback's rotation from the previous frame
  // (swapped with `ref` while it runs; reused, so allocation-free once warm).
  std::vector<ReferenceLevel> current_ref;
  // Levels [finest, current_ref_levels) of current_ref hold this frame's reference data (the
  // fallback's rotation built them): a keyframe switch on this frame takes them (0: none).
  int current_ref_levels = 0;
  // Per level, the keyframe's points for the geometric fallback's point-to-plane term
  // (TrackerAccess::build_plane_level): a normal-space sample of its depth pixels, built from
  // the keyframe's depth levels (kept, copied, for it) when the fallback first needs them.
  std::vector<ReferenceLevel> plane;
  std::vector<cv::Mat> ref_depth;
  bool plane_built = false;
  // bin_normals' buffers, kept across keyframes: its bins and one row's normals.
  NormalBins normal_bins;
  std::vector<float> row_nx, row_ny;
  std::vector<std::uint8_t> row_ok;
  bool has_ref = false;
  TimeNs ref_t_ns = 0;
  SE3 T_world_ref;

  // Disparity input (thesis 2.4, 3.10): the full-resolution map of the current and previous
  // frame, and per level the disparity read from it (disparity_at_level; full-res pixels).
  bool disparity_input = false;
  RectifiedStereo rig;
  cv::Mat disparity, prev_disparity;
  std::vector<cv::Mat> disparity_levels;

  // The current frame's depth: level 0 always, the coarser levels where a step needs them (the
  // depth residual, a new reference, the fallback); `depth_pyramid_current`: they are built.
  image::DepthPyramid depth_pyramid;
  bool depth_pyramid_current = false, prev_depth_pyramid_current = false;
  // Intensity gradients per level, each kept at its level's size: no reallocation per keyframe.
  std::vector<cv::Mat> gx, gy;
  std::vector<float> scores;  // per pixel of a level: squared gradient of a usable point, or 0
  std::vector<int> selected;  // the chosen pixels' indices, image order
  SelectionScratch selection_scratch;
  std::vector<float> depth_scratch;

  // Per-iteration buffers of the residual terms (sized to the largest level, padded to kLanes)
  // and the robust scales' scratch.
  TermBuffers photometric_buffers, geometric_buffers;
  std::vector<float> abs_residual;
  // Per level, each term's median |r| at the end of its last alignment there: where the next
  // alignment's scale estimate looks first (ResidualTerm::set_median_hint).
  std::vector<float> photometric_median_hint, geometric_median_hint;

  // Sequence state.
  bool has_prev = false;
  bool has_velocity = false;
  SE3 T_world_prev;
  SE3 velocity;  // T_prevprev_prev
  TimeNs t_prev = 0;
  TimeNs dt_prev = 0;

  void resize_levels(int levels) {
    const auto n = static_cast<std::size_t>(levels);
    ref.resize(n);
    current_ref.resize(n);
    plane.resize(n);
    ref_depth.resize(n);
    gx.resize(n);
    gy.resize(n);
    photometric_median_hint.assign(n, 0.0F);
    geometric_median_hint.assign(n, 0.0F);
  }

  // Rolling shutter (RollingShutter::readout_s > 0; it undistorts as well): the current
  // frame's raw depth, the caller's map itself (not a copy; held only during track(): its raw
  // intensity is intensity_raw), and whether the current, previous and reference frames were
  // rectified with a known rotation rate (a frame before any motion estimate is not).
  std::optional<image::RollingShutterRectifier> rolling_shutter;
  cv::Mat depth_raw;
  bool rs_frame_rectified = false, rs_ref_rectified = false;

  Impl(const PinholeCamera& cam, const DirectTrackerOptions& o, const RollingShutter& shutter)
      : undistorter(cam) {
    // The rectifier resamples as the finest level is sampled (rolling_shutter.hpp).
    if (shutter.readout_s > 0.0) {
      rolling_shutter.emplace(cam, shutter.readout_s, level_sampling(o, true));
    }
  }

  // The current frame's images and pyramid from the raw ones, undistorted and rectified for the
  // rotation rate `omega_rad_s` (camera frame).
  void rectify_rolling_shutter(const Eigen::Vector3d& omega_rad_s, const DirectTrackerOptions& o) {
    rolling_shutter->set_rotation_rate(omega_rad_s);
    rolling_shutter->rectify_intensity(intensity_raw, pyramid.base());
    rolling_shutter->rectify_depth(depth_raw, depth_pyramid.base());
    depth_pyramid_current = false;
    current_ref_levels = 0;
    pyramid.build_from_base(o.pyramid.levels, o.pyramid.filter);
    if (o.terms.geometric == GeometricTerm::kAlways) ensure_depth_pyramid(o);
  }

  // The current frame's images and depth trade places with the previous frame's (buffers
  // swapped, no copies): the fallback's rotation uses the previous frame in the other role, then
  // swaps back.
  void swap_current_and_previous() {
    std::swap(pyramid, prev_pyramid);
    std::swap(depth_pyramid, prev_depth_pyramid);
    std::swap(depth_pyramid_current, prev_depth_pyramid_current);
    std::swap(disparity, prev_disparity);
  }

  // The current frame's depth levels, built once per frame where a step needs them (the depth
  // residual, a new reference, the geometric fallback).
  void ensure_depth_pyramid(const DirectTrackerOptions& o) {
    if (depth_pyramid_current) return;
    depth_pyramid.build_from_base(o.pyramid.levels,
                                  static_cast<float>(o.pyramid.depth_max_relative_spread));
    depth_pyramid_current = true;
  }
};

DirectTracker::DirectTracker(const PinholeCamera& camera, const DirectTrackerOptions& options,
                             const RollingShutter& shutter)
    : camera_(camera.without_distortion()), options_(options) {
  options_.validate();
  if (!(shutter.readout_s >= 0.0 && shutter.readout_s <= 1.0)) {
    throw InputError("rolling-shutter readout " + std::to_string(shutter.readout_s) +
                     " s: must be in [0, 1] s (0: global shutter)");
  }
  impl_ = std::make_unique<Impl>(camera, options_, shutter);
  double s = 1.0;
  for (int l = 0; l < options_.pyramid.levels; ++l, s *= 0.5) {
    impl_->level_cameras.push_back(l == 0 ? camera_ : camera_.scaled(s));
  }
  impl_->resize_levels(options_.pyramid.levels);
}

DirectTracker::DirectTracker(const RectifiedStereo& rig, const DirectTrackerOptions& options)
    : options_(options), disparity_input_(true) {
  try {
    rig.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("stereo rig: ") + e.what());
  }
  options_.validate();
  if (options_.terms.geometric == GeometricTerm::kAlways) {
    throw InputError(
        "tracker option 'terms.geometric: always': needs depth maps; not available with "
        "disparity input (stereo)");
  }
  camera_ = rig.left();
  impl_ = std::make_unique<Impl>(camera_, options_, RollingShutter{});
  impl_->disparity_input = true;
  impl_->rig = rig;
  impl_->disparity_levels.resize(static_cast<std::size_t>(options_.pyramid.levels));
  double s = 1.0;
  for (int l = 0; l < options_.pyramid.levels; ++l, s *= 0.5) {
    impl_->level_cameras.push_back(l == 0 ? camera_ : camera_.scaled(s));
  }
  impl_->resize_levels(options_.pyramid.levels);
}

DirectTracker::~DirectTracker() = default;

void DirectTracker::reset() {
  impl_->has_ref = false;
  impl_->has_prev = false;
  impl_->has_velocity = false;
  impl_->current_ref_levels = 0;
  impl_->depth_raw.release();
}

namespace {

// Checks an image and its per-pixel map (depth or disparity, CV_32FC1 in `unit`) against the
// camera; returns an empty string when they can be used.
std::string check_image_and_map(const cv::Mat& image, const cv::Mat& map, const char* map_name,
                                const char* unit, const PinholeCamera& cam, const char* owner) {
  if (image.empty()) return "empty image";
  if (map.empty()) return std::string("empty ") + map_name + " map";
  const int t = image.type();
  if (t != CV_8UC3 && t != CV_8UC1 && t != CV_32FC1) {
    return "image type must be CV_8UC3, CV_8UC1 or CV_32FC1";
  }
  if (map.type() != CV_32FC1)
    return std::string(map_name) + " type must be CV_32FC1 (" + unit + ")";
  if (image.cols != cam.width() || image.rows != cam.height() || map.size() != image.size()) {
    return "frame size " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " / " +
           map_name + " " + std::to_string(map.cols) + "x" + std::to_string(map.rows) +
           " does not match the " + owner + " " + std::to_string(cam.width()) + "x" +
           std::to_string(cam.height());
  }
  return {};
}

std::string check_frame(const RgbdFrame& f, const PinholeCamera& cam) {
  return check_image_and_map(f.image, f.depth_m, "depth", "metres", cam, "camera's");
}

// A disparity frame of a rectified rig.
std::string check_frame(const DisparityFrame& f, const PinholeCamera& cam) {
  return check_image_and_map(f.image, f.disparity_px, "disparity", "pixels", cam, "rig's");
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Preparation: intensity, undistortion, pyramid of the current frame.
namespace {

void prepare_frame(DirectTracker::Impl& m, const RgbdFrame& f, const DirectTrackerOptions& o);
void prepare_frame(DirectTracker::Impl& m, const DisparityFrame& f, const DirectTrackerOptions& o);

}  // namespace

struct TrackerAccess {
  // What a reference is built for: a keyframe keeps a copy of its depth levels for the
  // geometric fallback's own points; the current frame as the fallback's rotation reference
  // does not (the keyframe's stay).
  enum class ReferenceRole { kKeyframe, kFallbackRotation };

  // Reference building: gradients, selection and the precomputed IC Jacobians per level, from
  // `first_level` up (the finer ones already hold this frame's; by default none do), and, for a
  // keyframe with the geometric fallback, the depth its own points are sampled from.
  static void build_reference(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                              const std::vector<PinholeCamera>& cams, int first_level = -1,
                              ReferenceRole role = ReferenceRole::kKeyframe) {
    prepare_reference_maps(m, o);
    const int finest = o.pyramid.finest_level;
    for (int l = std::max(first_level, finest); l < o.pyramid.levels; ++l) {
      build_reference_level(m, o, cams[static_cast<std::size_t>(l)], l);
    }
    if (role == ReferenceRole::kKeyframe && o.terms.geometric == GeometricTerm::kFallback &&
        !m.disparity_input) {
      for (int l = finest; l < o.pyramid.levels; ++l) {
        m.depth_pyramid.level(l).copyTo(m.ref_depth[static_cast<std::size_t>(l)]);
      }
      m.plane_built = false;
    }
    std::size_t max_count = 0;
    for (int l = finest; l < o.pyramid.levels; ++l) {
      max_count = std::max(max_count, m.ref[static_cast<std::size_t>(l)].x.size());
    }
    reserve_buffers(m, max_count);
    m.has_ref = true;
  }

  // The geometric fallback's points of the keyframe (Impl::plane), built once per keyframe.
  static void ensure_plane_points(DirectTracker::Impl& m, const DirectTrackerOptions& o) {
    if (m.plane_built) return;
    std::size_t max_count = 0;
    for (int l = o.pyramid.finest_level; l < o.pyramid.levels; ++l) {
      build_plane_level(m, o, m.level_cameras[static_cast<std::size_t>(l)], l);
      max_count = std::max(max_count, m.plane[static_cast<std::size_t>(l)].x.size());
    }
    reserve_buffers(m, max_count);
    m.plane_built = true;
  }

  static void reserve_buffers(DirectTracker::Impl& m, std::size_t max_count) {
    if (m.abs_residual.size() < max_count) m.abs_residual.resize(max_count);
    m.photometric_buffers.reserve(max_count);
    m.geometric_buffers.reserve(max_count);
    m.geometric_buffers.reserve_jacobian(max_count);
  }

  // The per-level maps the points are read from. With the geometric residual, prepare_frame()
  // already built this frame's depth pyramid. Disparity input: each level reads the
  // full-resolution disparity (thesis 3.10).
  static void prepare_reference_maps(DirectTracker::Impl& m, const DirectTrackerOptions& o) {
    if (m.disparity_input) {
      for (int l = o.pyramid.finest_level; l < o.pyramid.levels; ++l) {
        disparity_at_level(m.disparity, l, static_cast<float>(o.pyramid.depth_max_relative_spread),
                           m.disparity_levels[static_cast<std::size_t>(l)]);
      }
    } else {
      m.ensure_depth_pyramid(o);
    }
  }

  // One level's points (padded to whole SIMD lanes), Jacobians, normals and median depth.
  static void build_reference_level(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                                    const PinholeCamera& cam, int l) {
    const bool disp = m.disparity_input;
    ReferenceLevel& L = m.ref[static_cast<std::size_t>(l)];
    const cv::Mat& img = m.pyramid.level(l);
    // Depth (m) or, with disparity input, disparity (full-resolution pixels).
    const cv::Mat& dep =
        disp ? m.disparity_levels[static_cast<std::size_t>(l)] : m.depth_pyramid.level(l);
    set_level_camera(cam, img, L);
    const auto level = static_cast<std::size_t>(l);
    image::central_gradients(img, m.gx[level], m.gy[level]);
    select_points(m, o, img, dep, m.gx[level], m.gy[level]);
    const int n = static_cast<int>(m.selected.size());
    const auto padded = static_cast<std::size_t>(pad_to_lanes(n));
    reset_points(L, n, padded);
    m.depth_scratch.clear();
    const DisparitySpaceCamera dcam =
        disp ? DisparitySpaceCamera::at_level(m.rig, l) : DisparitySpaceCamera{};
    const PointSource src{img, m.gx[level], m.gy[level], dep, cam, dcam};
    for (int i = 0; i < n; ++i) add_point(m, o, src, m.selected[static_cast<std::size_t>(i)], i, L);
    if (!m.depth_scratch.empty()) {
      const auto count = static_cast<int>(m.depth_scratch.size());
      L.median_depth = kernels::select_kth(m.depth_scratch.data(), count, count / 2);
    } else {
      L.median_depth = 0.0;
    }
    set_depth_noise_scale(o, L);
  }

  // The point-to-plane residuals' depth-noise scales (ReferenceLevel::depth_noise_scale).
  static void set_depth_noise_scale(const DirectTrackerOptions& o, ReferenceLevel& L) {
    L.depth_noise_scale.clear();
    if (o.terms.geometric == GeometricTerm::kOff || !(o.terms.depth_noise_per_m > 0.0) ||
        !(L.median_depth > 0.0)) {
      return;
    }
    L.depth_noise_scale.assign(L.x.size(), 0.0F);
    const auto zm = static_cast<float>(L.median_depth);
    for (std::size_t k = 0; k < static_cast<std::size_t>(L.count); ++k) {
      const float s = zm / L.z[k];
      L.depth_noise_scale[k] = s * s;
    }
  }

  // Score = squared gradient where the point is usable (depth in range, gradient above
  // min_gradient), 0 elsewhere and on the border; branch-free, so it vectorises. Then the
  // strongest selection.max_points in image order (point_selection.hpp) into m.selected.
  static void select_points(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                            const cv::Mat& img, const cv::Mat& dep, const cv::Mat& gx,
                            const cv::Mat& gy) {
    // The depth range; in disparity space d in [f B / max_depth, f B / min_depth], the same
    // numbers on every level (d stays in full-resolution pixels). Without a far limit
    // (max_depth .inf) a disparity must still be positive: d = 0 has no depth.
    const bool disp = m.disparity_input;
    const double fb = m.rig.f * m.rig.baseline_m;
    const auto zmin = disp ? std::max(static_cast<float>(fb / o.selection.max_depth_m),
                                      std::numeric_limits<float>::min())
                           : static_cast<float>(o.selection.min_depth_m);
    const auto zmax =
        static_cast<float>(disp ? fb / o.selection.min_depth_m : o.selection.max_depth_m);
    const auto g2min = static_cast<float>(o.selection.min_gradient * o.selection.min_gradient);
    m.scores.assign(static_cast<std::size_t>(img.rows) * static_cast<std::size_t>(img.cols), 0.0F);
    for (int y = 1; y < img.rows - 1; ++y) {
      const float* d = dep.ptr<float>(y);
      const float* gxr = gx.ptr<float>(y);
      const float* gyr = gy.ptr<float>(y);
      float* sc = m.scores.data() + static_cast<std::ptrdiff_t>(y) * img.cols;
      for (int x = 1; x < img.cols - 1; ++x) {
        const float z = d[x];
        const float g2 = gxr[x] * gxr[x] + gyr[x] * gyr[x];
        const bool ok = (z >= zmin) & (z <= zmax) & (g2 >= g2min) & (g2 > 0.0F);
        sc[x] = ok ? g2 : 0.0F;
      }
    }
    select_strongest(m.scores, static_cast<std::size_t>(std::max(0, o.selection.max_points)),
                     m.selected, m.selection_scratch);
  }

  // The level's pinhole model and size (the image's or depth level's, equal in size).
  static void set_level_camera(const PinholeCamera& cam, const cv::Mat& level, ReferenceLevel& L) {
    L.fx = static_cast<float>(cam.fx());
    L.fy = static_cast<float>(cam.fy());
    L.cx = static_cast<float>(cam.cx());
    L.cy = static_cast<float>(cam.cy());
    L.width = level.cols;
    L.height = level.rows;
  }

  // n points, padded to whole SIMD lanes with points that weigh nothing.
  static void reset_points(ReferenceLevel& L, int n, std::size_t padded) {
    L.count = n;
    L.x.assign(padded, 0.0F);
    L.y.assign(padded, 0.0F);
    L.z.assign(padded, 1.0F);
    L.intensity.assign(padded, 0.0F);
    for (auto& col : L.jac) col.assign(padded, 0.0F);
    L.nx.assign(padded, 0.0F);
    L.ny.assign(padded, 0.0F);
    L.nz.assign(padded, 0.0F);
    L.n_dot_p.assign(padded, 0.0F);
    L.has_normal.assign(padded, 0);
    L.normal_count = 0;
  }

  // What a level's points are read from.
  struct PointSource {
    const cv::Mat& img;
    const cv::Mat& gx;  // its intensity gradients
    const cv::Mat& gy;
    const cv::Mat& dep;  // depth (m) or disparity (full-resolution px)
    const PinholeCamera& cam;
    DisparitySpaceCamera dcam;  // disparity input only
  };

  // A reference point before it is stored: its pixel, depth and 3D position.
  struct PointDepth {
    Eigen::Vector3d P;
    double z = 0.0;
    int u = 0, v = 0;
  };

  // Selected pixel `idx` as point i of level L: position, Jacobian (pose, gain, bias) and, for
  // the geometric residual, its normal.
  static void add_point(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                        const PointSource& src, int idx, int i, ReferenceLevel& L) {
    const cv::Mat& img = src.img;
    const PinholeCamera& cam = src.cam;
    const int u = idx % img.cols;
    const int v = idx / img.cols;
    const float* img_data = img.ptr<float>();
    const float* gx_data = src.gx.ptr<float>();
    const float* gy_data = src.gy.ptr<float>();
    PointDepth pd{Eigen::Vector3d::Zero(), src.dep.ptr<float>()[idx], u, v};
    Vector8d J;
    if (m.disparity_input) {
      // P = Gamma_l^-1 (x, y, d) and the Jacobian in disparity space (thesis 3.7, 3.36).
      const double d = pd.z;
      pd.P = src.dcam.point(u, v, d);
      pd.z = pd.P.z();
      J.head<6>() =
          disparity_photometric_pose_jacobian(src.dcam, u, v, d, gx_data[idx], gy_data[idx])
              .transpose();
      J(6) = img_data[idx];
      J(7) = 1.0;
    } else {
      pd.P = back_project(cam, u, v, pd.z);
    }
    if (!m.disparity_input) {
      J = photometric_jacobian(pd.P, gx_data[idx], gy_data[idx], cam.fx(), cam.fy(), img_data[idx]);
    }
    const auto k = static_cast<std::size_t>(i);
    L.x[k] = static_cast<float>(pd.P.x());
    L.y[k] = static_cast<float>(pd.P.y());
    L.z[k] = static_cast<float>(pd.P.z());
    L.intensity[k] = img_data[idx];
    for (std::size_t c = 0; c < 8; ++c) L.jac[c][k] = static_cast<float>(J(static_cast<long>(c)));
    if (o.terms.geometric != GeometricTerm::kOff) add_normal(o, src, pd, k, L);
    m.depth_scratch.push_back(static_cast<float>(pd.z));
  }

  // The point's surface normal, where the depth around it gives a reliable one.
  static void add_normal(const DirectTrackerOptions& o, const PointSource& src,
                         const PointDepth& pd, std::size_t k, ReferenceLevel& L) {
    Eigen::Vector3d normal;
    if (normal_at(src.dep, src.cam, pd.u, pd.v,
                  static_cast<float>(o.terms.depth_max_relative_spread), pd.P, normal)) {
      L.nx[k] = static_cast<float>(normal.x());
      L.ny[k] = static_cast<float>(normal.y());
      L.nz[k] = static_cast<float>(normal.z());
      L.n_dot_p[k] = static_cast<float>(normal.dot(pd.P));
      L.has_normal[k] = 1;
      ++L.normal_count;
    }
  }

  // Unit normal of the surface at pixel (u, v) of a depth level, from the back-projected
  // neighbours (central differences), facing the camera. False near depth discontinuities,
  // holes, and at grazing angles, where a normal is not reliable.
  static bool normal_at(const cv::Mat& dep, const PinholeCamera& cam, int u, int v,
                        float max_spread, const Eigen::Vector3d& P, Eigen::Vector3d& n) {
    if (u < 1 || v < 1 || u >= dep.cols - 1 || v >= dep.rows - 1) return false;
    const float z0 = dep.at<float>(v, u);
    const float zs[4] = {dep.at<float>(v, u - 1), dep.at<float>(v, u + 1), dep.at<float>(v - 1, u),
                         dep.at<float>(v + 1, u)};
    for (float z : zs) {
      if (!(z > 0.0F && z < 1e3F) || std::fabs(z - z0) > 2.0F * max_spread * z0) return false;
    }
    auto back = [&](int uu, int vv, double z) {
      return Eigen::Vector3d((uu - cam.cx()) / cam.fx() * z, (vv - cam.cy()) / cam.fy() * z, z);
    };
    const Eigen::Vector3d dx = back(u + 1, v, zs[1]) - back(u - 1, v, zs[0]);
    const Eigen::Vector3d dy = back(u, v + 1, zs[3]) - back(u, v - 1, zs[2]);
    n = dx.cross(dy);
    const double len = n.norm();
    if (!(len > 0.0)) return false;
    n /= len;
    if (n.dot(P) > 0.0) n = -n;
    return -n.dot(P) > 0.2 * P.norm();  // not grazing: within ~78 deg of the viewing ray
  }

  // The geometric fallback's points on level l of the keyframe (Impl::plane): the depth pixels
  // with a reliable normal, a normal-space sample (Rusinkiewicz & Levoy 2001) of
  // selection.max_points. The photometric points sit on intensity edges, often at depth
  // edges; these are spread over the surfaces and over the normals' directions, so that every
  // direction of the motion is held by some surface.
  static void build_plane_level(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                                const PinholeCamera& cam, int l) {
    const ReferenceLevel& L = m.ref[static_cast<std::size_t>(l)];
    ReferenceLevel& G = m.plane[static_cast<std::size_t>(l)];
    const cv::Mat& dep = m.ref_depth[static_cast<std::size_t>(l)];
    set_level_camera(cam, dep, G);
    G.median_depth = L.median_depth;
    const auto spread = static_cast<float>(o.terms.depth_max_relative_spread);
    bin_normals(m, dep, cam, spread, o);
    sample_bins(m.normal_bins, o.selection.max_points, m.selected);
    const int n = static_cast<int>(m.selected.size());
    reset_points(G, n, static_cast<std::size_t>(pad_to_lanes(n)));
    for (int i = 0; i < n; ++i) {
      const int idx = m.selected[static_cast<std::size_t>(i)];
      const int u = idx % dep.cols;
      const int v = idx / dep.cols;
      const double z = dep.ptr<float>()[idx];
      const PointDepth pd{back_project(cam, u, v, z), z, u, v};
      const auto k = static_cast<std::size_t>(i);
      G.x[k] = static_cast<float>(pd.P.x());
      G.y[k] = static_cast<float>(pd.P.y());
      G.z[k] = static_cast<float>(pd.P.z());
      add_normal(o, PointSource{dep, dep, dep, dep, cam, {}}, pd, k, G);
    }
    set_depth_noise_scale(o, G);
  }

  static Eigen::Vector3d back_project(const PinholeCamera& cam, int u, int v, double z) {
    return {(u - cam.cx()) / cam.fx() * z, (v - cam.cy()) / cam.fy() * z, z};
  }

  // The pixels of a grid of at least ~4 x selection.max_points over the depth level (its step
  // rounded down) whose depth is in the selection's range and whose normal is reliable, each in
  // its normal's bin (m.normal_bins). The normals of a sampled row are computed for all its
  // columns at once (kernels::surface_normal_row, SIMD).
  static void bin_normals(DirectTracker::Impl& m, const cv::Mat& dep, const PinholeCamera& cam,
                          float spread, const DirectTrackerOptions& o) {
    NormalBins& bins = m.normal_bins;
    for (auto& b : bins) b.clear();
    // selection.max_points 0 (no limit): every pixel is a candidate.
    const int n = o.selection.max_points;
    const double cells = n > 0 ? static_cast<double>(dep.cols) * dep.rows / (4.0 * n) : 1.0;
    const int step = std::max(1, static_cast<int>(std::sqrt(cells)));
    const auto zmin = static_cast<float>(o.selection.min_depth_m);
    const auto zmax = static_cast<float>(o.selection.max_depth_m);
    const auto w = static_cast<std::size_t>(dep.cols);
    m.row_nx.resize(w);
    m.row_ny.resize(w);
    m.row_ok.resize(w);
    kernels::NormalRow row;
    row.width = dep.cols;
    row.fx = static_cast<float>(cam.fx());
    row.fy = static_cast<float>(cam.fy());
    row.cx = static_cast<float>(cam.cx());
    row.cy = static_cast<float>(cam.cy());
    row.max_spread = 2.0F * spread;
    auto bin = [](float c) {
      return std::clamp(static_cast<int>((c + 1.0F) * 0.5F * kNormalBins), 0, kNormalBins - 1);
    };
    for (int v = 1; v < dep.rows - 1; v += step) {
      row.up = dep.ptr<float>(v - 1);
      row.mid = dep.ptr<float>(v);
      row.down = dep.ptr<float>(v + 1);
      row.v = v;
      kernels::surface_normal_row(row, m.row_nx.data(), m.row_ny.data(), m.row_ok.data());
      for (int u = 1; u < dep.cols - 1; u += step) {
        const auto c = static_cast<std::size_t>(u);
        if (!(row.mid[u] >= zmin && row.mid[u] <= zmax) || m.row_ok[c] == 0) continue;
        bins[static_cast<std::size_t>(bin(m.row_ny[c]) * kNormalBins + bin(m.row_nx[c]))].push_back(
            v * dep.cols + u);
      }
    }
  }

  // Up to n candidates (n <= 0: all), as evenly over the bins as they allow (equal shares; what a
  // small bin leaves goes to the others), each bin's share spread evenly over its candidates.
  static void sample_bins(const NormalBins& bins, int n, std::vector<int>& out) {
    std::array<std::size_t, kNormalBins * kNormalBins> quota{};
    std::size_t total = 0;
    for (const auto& b : bins) total += b.size();
    std::size_t left = n > 0 ? std::min(total, static_cast<std::size_t>(n)) : total;
    while (left > 0) {
      std::size_t open = 0;
      for (std::size_t b = 0; b < bins.size(); ++b) open += quota[b] < bins[b].size() ? 1 : 0;
      if (open == 0) break;
      const std::size_t share = std::max<std::size_t>(1, left / open);
      for (std::size_t b = 0; b < bins.size() && left > 0; ++b) {
        const std::size_t add = std::min({share, bins[b].size() - quota[b], left});
        quota[b] += add;
        left -= add;
      }
    }
    out.clear();
    for (std::size_t b = 0; b < bins.size(); ++b) {
      for (std::size_t j = 0; j < quota[b]; ++j) {
        out.push_back(bins[b][j * bins[b].size() / quota[b]]);
      }
    }
  }
};

namespace {

void prepare_frame(DirectTracker::Impl& m, const DisparityFrame& f, const DirectTrackerOptions& o) {
  m.current_ref_levels = 0;
  std::swap(m.pyramid, m.prev_pyramid);
  std::swap(m.disparity, m.prev_disparity);
  // Rectified views: no undistortion.
  image::to_intensity(f.image, m.pyramid.base());
  f.disparity_px.copyTo(m.disparity);
  m.pyramid.build_from_base(o.pyramid.levels, o.pyramid.filter);
}

void prepare_frame(DirectTracker::Impl& m, const RgbdFrame& f, const DirectTrackerOptions& o) {
  m.current_ref_levels = 0;
  std::swap(m.pyramid, m.prev_pyramid);
  std::swap(m.depth_pyramid, m.prev_depth_pyramid);
  std::swap(m.depth_pyramid_current, m.prev_depth_pyramid_current);
  m.depth_pyramid_current = false;
  if (m.rolling_shutter) {
    image::to_intensity(f.image, m.intensity_raw);
    // Rolling shutter: rectified with the rotation rate the constant-velocity prior predicts
    // (the last frame's motion); the raw depth stays at hand for a later rectification with the
    // frame's own rate (track_prepared).
    m.depth_raw = f.depth_m;
    m.rs_frame_rectified = m.has_velocity && m.dt_prev > 0;
    m.rectify_rolling_shutter(m.rs_frame_rectified
                                  ? Eigen::Vector3d(m.velocity.so3().log() / ns_to_s(m.dt_prev))
                                  : Eigen::Vector3d::Zero(),
                              o);
    return;
  }
  if (m.undistorter.is_identity()) {
    image::to_intensity(f.image, m.pyramid.base());
  } else {
    image::to_intensity(f.image, m.intensity_raw);
    m.undistorter.undistort_intensity(m.intensity_raw, m.pyramid.base());
  }
  m.undistorter.undistort_depth(f.depth_m, m.depth_pyramid.base());
  m.pyramid.build_from_base(o.pyramid.levels, o.pyramid.filter);
  if (o.terms.geometric == GeometricTerm::kAlways) m.ensure_depth_pyramid(o);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Alignment of the prepared current frame to the reference, coarse to fine.
namespace {

// The residuals of one alignment and how its health is judged.
struct AlignTerms {
  bool geometric = false;  ///< point-to-plane residuals with the photometric ones
  /// The joint residual's health (the geometric fallback and terms.geometric: always): the
  /// photometric health is judged on the finest level whose robust sigma passes max_sigma (a
  /// blurred image still agrees with the keyframe at the scales the blur left), and the
  /// geometric residuals have health checks of their own.
  bool fallback_checks = false;
  /// The point-to-plane term on the keyframe's own points (Impl::plane) instead of the
  /// photometric ones: the geometric fallback against the keyframe.
  bool plane_points = false;

  static constexpr AlignTerms photometric() { return {false, false, false}; }
  static constexpr AlignTerms joint() { return {true, true, false}; }
  /// The geometric fallback against the keyframe: the joint residual, its point-to-plane term on
  /// the keyframe's own points.
  static constexpr AlignTerms keyframe_fallback() { return {true, true, true}; }

  // The points of the level's point-to-plane term.
  [[nodiscard]] const ReferenceLevel& geometric_points(const DirectTracker::Impl& m,
                                                       int level) const {
    const auto l = static_cast<std::size_t>(level);
    return plane_points ? m.plane[l] : m.ref[l];
  }
};

struct AlignOutcome {
  SE3 T_cur_ref;
  double alpha = 1.0, beta = 0.0;
  TrackResult result;              // health fields only
  double max_level_jump_px = 0.0;  // largest move of a level from its coarser one, in coarser px
};

}  // namespace

// ---------------------------------------------------------------------------------------
// One pyramid level of the alignment: its residual terms and their solver (level_solver.hpp).
namespace {

// The level whose photometric figures the health checks judge (AlignTerms::fallback_checks).
struct HealthLevel {
  double sigma = 0.0;
  int inliers = 0, points = 1, level = 0;
  bool passed = false;
};

// The residual terms of one level: the photometric one always and, with `geometric`, the
// point-to-plane one where the level has enough points with a normal.
class LevelTerms {
 public:
  LevelTerms(DirectTracker::Impl& m, const DirectTrackerOptions& o, int level,
             const AlignTerms& terms)
      : photometric_(
            m.ref[static_cast<std::size_t>(level)], m.pyramid.level(level),
            level_sampling(o, level == o.pyramid.finest_level), m.photometric_buffers,
            static_cast<float>(o.robust.tukey_c),
            {o.terms.gain_bias ? 8 : 6, o.robust.min_sigma, o.robust.sigma_freeze_change, 0.0}),
        geometric_(geometric_term(m, o, level, terms)) {
    const ReferenceLevel& L = m.ref[static_cast<std::size_t>(level)];
    list_[0] = &photometric_;
    if (geometric_) {
      list_[1] = &*geometric_;
      size_ = 2;
    }
    m.photometric_buffers.pad(L.count);
    m.geometric_buffers.pad(terms.geometric_points(m, level).count);
    const auto l = static_cast<std::size_t>(level);
    photometric_.set_median_hint(m.photometric_median_hint[l]);
    if (geometric_) geometric_->set_median_hint(m.geometric_median_hint[l]);
  }

  // Keeps the terms' last medians for the next alignment of this level.
  void keep_median_hints(DirectTracker::Impl& m, int level) const {
    const auto l = static_cast<std::size_t>(level);
    m.photometric_median_hint[l] = photometric_.median_hint();
    if (geometric_) m.geometric_median_hint[l] = geometric_->median_hint();
  }

  [[nodiscard]] std::span<ResidualTerm* const> list() const { return {list_.data(), size_}; }
  [[nodiscard]] const PointToPlaneTerm* geometric() const {
    return geometric_ ? &*geometric_ : nullptr;
  }

 private:
  // Built in place (a prvalue: the term is neither copied nor moved).
  static std::optional<PointToPlaneTerm> geometric_term(DirectTracker::Impl& m,
                                                        const DirectTrackerOptions& o, int level,
                                                        const AlignTerms& terms) {
    const ReferenceLevel& L = terms.geometric_points(m, level);
    if (!terms.geometric || L.normal_count < o.health.min_points) return std::nullopt;
    // The geometric scale is not below the sensor's depth noise at the level's median depth:
    // on exact (rendered) or very clean depth the MAD of a misaligned pair counts the points
    // whose residual the motion leaves at zero (a wall sliding in its own plane), and 1/sigma^2
    // weights then outvote the photometric residuals in steps that raise the robust cost. It
    // freezes at the photometric rule's relative change (1e-6 of ~0.02 grey: 5e-5).
    const double floor = std::max(o.terms.min_depth_sigma_m,
                                  o.terms.depth_noise_per_m * L.median_depth * L.median_depth);
    return std::optional<PointToPlaneTerm>(
        std::in_place, L, m.depth_pyramid.level(level),
        static_cast<float>(o.terms.depth_max_relative_spread), m.geometric_buffers,
        static_cast<float>(o.robust.tukey_c), ScaleRule{6, floor, 0.0, 5e-5});
  }

  PhotometricTerm photometric_;
  std::optional<PointToPlaneTerm> geometric_;
  std::array<ResidualTerm*, 2> list_{};
  std::size_t size_ = 1;
};

// How far a level moved the coarser level's estimate, in pixels of the coarser level.
double level_jump_px(const ReferenceLevel& coarser, const SE3& T_level_start, const SE3& T) {
  const SE3 D = T_level_start.inverse() * T;
  const double zc = std::max(0.1, coarser.median_depth);
  return static_cast<double>(coarser.fx) * (D.so3().log().norm() + D.translation().norm() / zc);
}

// The finest level's figures, judged on `health`'s level, and the pose covariance.
void finish_finest_level(const LevelStats& stats, const PointToPlaneTerm* geo, LevelEnd end,
                         const HealthLevel& health, const ReferenceLevel& L, int params,
                         TrackResult& res) {
  res.converged = end == LevelEnd::kConverged;
  res.sigma = health.sigma;
  res.photometric_level = health.level;
  res.depth_sigma = geo ? geo->sigma() : 0.0;
  res.depth_points = geo ? geo->valid() : 0;
  res.depth_inlier_ratio =
      geo ? static_cast<double>(geo->inliers()) / std::max(1, geo->points_with_normal()) : 0.0;
  res.points = L.count;
  res.overlap = static_cast<double>(stats.inside) / L.count;
  res.inlier_ratio = static_cast<double>(health.inliers) / health.points;
  // Marginal covariance of the pose: the 6x6 block of H^-1 (H holds the 1/sigma^2).
  Eigen::MatrixXd Hp = stats.H.topLeftCorner(params, params);
  Eigen::MatrixXd cov = Hp.ldlt().solve(Eigen::MatrixXd::Identity(params, params));
  res.covariance = cov.topLeftCorner<6, 6>();
}

// Never report success without overlap and agreement.
void check_health(const SE3& T_cur_ref, const DirectTrackerOptions& o, const AlignTerms& terms,
                  TrackResult& res) {
  const SE3 T_ref_cur = T_cur_ref.inverse();
  if (!res.covariance.allFinite() || !T_cur_ref.translation().allFinite()) {
    res.failure = TrackFailure::kNumerical;
    res.failure_detail = "non-finite estimate";
  } else if (res.overlap < o.health.min_overlap) {
    res.failure = TrackFailure::kNoOverlap;
    res.failure_detail = "overlap " + std::to_string(res.overlap) + " < min_overlap";
  } else if (res.sigma > o.health.max_sigma) {
    res.failure = TrackFailure::kHighResidual;
    res.failure_detail = "robust sigma " + std::to_string(res.sigma) + " > max_sigma";
  } else if (res.inlier_ratio < o.health.min_inlier_ratio) {
    res.failure = TrackFailure::kLowInlierRatio;
    res.failure_detail = "inlier ratio " + std::to_string(res.inlier_ratio) + " < min_inlier_ratio";
  } else if (terms.fallback_checks && (res.depth_points < o.health.min_points ||
                                       res.depth_inlier_ratio < o.health.min_inlier_ratio)) {
    res.failure = TrackFailure::kLowInlierRatio;
    res.failure_detail = "geometric fallback: " + std::to_string(res.depth_points) +
                         " point-to-plane residuals, inlier ratio " +
                         std::to_string(res.depth_inlier_ratio);
  } else if (T_ref_cur.translation().norm() > o.health.max_translation_m ||
             rotation_angle_deg(T_ref_cur) > o.health.max_rotation_deg) {
    res.failure = TrackFailure::kImplausibleMotion;
    res.failure_detail = "motion to the reference beyond max_translation_m/max_rotation_deg";
  }
}

}  // namespace

struct AlignRunner {
  // The photometric alignment and, where it asks for it, the geometric fallback
  // (TermsOptions::geometric = fallback, FallbackOptions): on a high residual (blur), or when a
  // finer level left the coarser one's estimate by more than max_level_jump_px (the photometric
  // data are ambiguous at that scale: blur, rolling shutter, aliasing). The fallback's result
  // replaces the photometric one only if it passes its own health checks. With
  // terms.geometric: always, the joint alignment alone (align_joint).
  static AlignOutcome align_with_fallback(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                                          const SE3& T_cur_ref_guess) {
    if (o.terms.geometric == GeometricTerm::kAlways) return align_joint(m, o, T_cur_ref_guess);
    AlignOutcome a = align(m, o, T_cur_ref_guess, AlignTerms::photometric());
    if (o.terms.geometric != GeometricTerm::kFallback || m.disparity_input ||
        !(jumped(a, o) || a.result.failure == TrackFailure::kHighResidual)) {
      return a;
    }
    m.ensure_depth_pyramid(o);
    TrackerAccess::ensure_plane_points(m, o);
    AlignOutcome b = align(m, o, T_cur_ref_guess, AlignTerms::keyframe_fallback());
    b.result.iterations += a.result.iterations;
    if (!b.result.ok()) {
      a.result.iterations = b.result.iterations;
      return a;
    }
    b.result.geometric_fallback = true;
    return b;
  }

  // terms.geometric: always: the joint residual on every pair, with the fallback's health checks
  // (a blurred frame is judged where its images still agree with the keyframe's, not failed on
  // its finest level). Where the photometric data alone would have called the fallback (the
  // images agree only on a coarser level, or a finer level jumped), the frame is marked
  // geometric_fallback and takes the fallback's policy: its rotation from the previous frame,
  // and, blurred, it becomes the keyframe.
  static AlignOutcome align_joint(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                                  const SE3& T_cur_ref_guess) {
    AlignOutcome j = align(m, o, T_cur_ref_guess, AlignTerms::joint());
    j.result.geometric_fallback =
        j.result.ok() && (j.result.photometric_level > o.pyramid.finest_level || jumped(j, o));
    return j;
  }

  [[nodiscard]] static bool jumped(const AlignOutcome& a, const DirectTrackerOptions& o) {
    return a.result.ok() && a.max_level_jump_px > o.fallback.max_level_jump_px;
  }

  // The fallback's rotation against the previous frame
  // (FallbackOptions::rotation_from_previous_frame): the current frame is the
  // reference (its own, blurred, gradients, points and normals) and the previous frame, blurred
  // alike in a fast motion, is aligned to it with the joint residual and the fallback's checks.
  // The current frame's reference data are built in a buffer of their own, swapped in and out
  // (no copies): the keyframe's stay. Returns T_prev_cur, or nothing where it fails.
  static std::optional<SE3> align_previous_to_current(DirectTracker::Impl& m,
                                                      const DirectTrackerOptions& o,
                                                      const std::vector<PinholeCamera>& cams,
                                                      const SE3& T_prev_cur_guess,
                                                      int& iterations) {
    // Levels from fallback.rotation_coarsest_level down: the guess is the keyframe fallback's
    // estimate, a fraction of a pixel off there. Both depth pyramids stay full height (the
    // keyframe switch and the next frame read them).
    DirectTrackerOptions levels = o;
    levels.pyramid.levels = std::clamp(o.fallback.rotation_coarsest_level + 1,
                                       o.pyramid.finest_level + 1, o.pyramid.levels);
    const bool keyframe_rectified = m.rs_ref_rectified;
    std::swap(m.ref, m.current_ref);
    m.rs_ref_rectified = m.rs_frame_rectified;
    m.ensure_depth_pyramid(o);
    TrackerAccess::build_reference(m, levels, cams, -1,
                                   TrackerAccess::ReferenceRole::kFallbackRotation);
    m.swap_current_and_previous();
    m.ensure_depth_pyramid(o);
    // align() maps reference (current frame) points into the frame it samples (the previous).
    const AlignOutcome b = align(m, levels, T_prev_cur_guess, AlignTerms::joint());
    m.swap_current_and_previous();
    std::swap(m.ref, m.current_ref);
    m.current_ref_levels = levels.pyramid.levels;
    m.rs_ref_rectified = keyframe_rectified;
    iterations += b.result.iterations;
    if (!b.result.ok()) return std::nullopt;
    return b.T_cur_ref;
  }

  // Coarse to fine over the pyramid, each level from the coarser one's estimate, then the
  // health checks.
  static AlignOutcome align(DirectTracker::Impl& m, const DirectTrackerOptions& o,
                            const SE3& T_cur_ref_guess, const AlignTerms& terms) {
    AlignOutcome out;
    TrackResult& res = out.result;
    Estimate est{T_cur_ref_guess};
    HealthLevel health;
    health.level = o.pyramid.finest_level;
    for (int l = o.pyramid.levels - 1; l >= o.pyramid.finest_level; --l) {
      const ReferenceLevel& L = m.ref[static_cast<std::size_t>(l)];
      const bool finest = (l == o.pyramid.finest_level);
      if (L.count < o.health.min_points) {
        if (!finest) continue;  // a coarse level without enough points is skipped
        res.failure = TrackFailure::kTooFewPoints;
        res.failure_detail = "reference has " + std::to_string(L.count) +
                             " usable points on level " + std::to_string(l) + " (min_points " +
                             std::to_string(o.health.min_points) + ")";
        out.T_cur_ref = est.T_cur_ref;
        return out;
      }
      const SE3 T_level_start = est.T_cur_ref;
      const LevelTerms level_terms(m, o, l, terms);
      LevelSolver solver(level_terms.list(), SolverRules::for_level(o, l, L), l, L.count,
                         m.abs_residual.data(), est, res);
      const LevelEnd end = solver.run();
      level_terms.keep_median_hints(m, l);
      if (end == LevelEnd::kFailed) {
        out.T_cur_ref = est.T_cur_ref;
        return out;
      }
      if (l + 1 < o.pyramid.levels) {
        out.max_level_jump_px = std::max(
            out.max_level_jump_px,
            level_jump_px(m.ref[static_cast<std::size_t>(l + 1)], T_level_start, est.T_cur_ref));
      }
      // Coarse to fine: with fallback_checks the finest level that passes (or, while none has,
      // the current one); else the finest level.
      const LevelStats& stats = solver.stats();
      const bool record =
          terms.fallback_checks ? (stats.sigma <= o.health.max_sigma || !health.passed) : finest;
      if (record) {
        health.passed = health.passed || stats.sigma <= o.health.max_sigma;
        health.level = l;
        health.sigma = stats.sigma;
        health.inliers = stats.inliers;
        health.points = L.count;
      }
      if (finest) {
        finish_finest_level(stats, level_terms.geometric(), end, health, L,
                            o.terms.gain_bias ? 8 : 6, res);
      }
    }
    out.T_cur_ref = est.T_cur_ref;
    out.alpha = est.alpha;
    out.beta = est.beta;
    res.gain = est.alpha - 1.0;
    res.bias = est.beta;
    check_health(est.T_cur_ref, o, terms, res);
    return out;
  }
};

// ---------------------------------------------------------------------------------------

namespace {

// The frame's kind must match the tracker's input; empty when it does.
std::string check_input_kind(bool disparity_input, bool disparity_frame) {
  if (disparity_input == disparity_frame) return {};
  return disparity_input ? "this tracker was built from a stereo rig: it takes DisparityFrame"
                         : "this tracker was built from a camera: it takes RgbdFrame";
}

template <typename Frame>
TrackResult invalid_input(const Frame& frame, std::string detail, const SE3& T_world_cam) {
  TrackResult result;
  result.t_ns = frame.t_ns;
  result.failure = TrackFailure::kInvalidInput;
  result.failure_detail = std::move(detail);
  result.T_world_cam = T_world_cam;
  // Nothing was aligned: no ratio was measured.
  result.inlier_ratio = result.overlap = std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace

TrackResult DirectTracker::track(const RgbdFrame& frame) {
  Impl& m = *impl_;
  std::string bad = check_input_kind(disparity_input_, false);
  if (bad.empty()) bad = check_frame(frame, camera_);
  if (!bad.empty()) return invalid_input(frame, bad, m.has_prev ? m.T_world_prev : SE3());
  prepare_frame(m, frame, options_);
  TrackResult result = track_prepared(frame.t_ns);
  m.depth_raw.release();  // the caller's buffer: not held past the call
  return result;
}

TrackResult DirectTracker::track(const DisparityFrame& frame) {
  Impl& m = *impl_;
  std::string bad = check_input_kind(disparity_input_, true);
  if (bad.empty()) bad = check_frame(frame, camera_);
  if (!bad.empty()) return invalid_input(frame, bad, m.has_prev ? m.T_world_prev : SE3());
  prepare_frame(m, frame, options_);
  return track_prepared(frame.t_ns);
}

namespace {

// One frame of the tracking policy (thesis 5.2): the first frame defines the world; later ones
// are aligned to the keyframe from a constant-velocity prediction and switch the keyframe when
// they leave it; a failure restarts from the frame itself.
class TrackingStep {
 public:
  TrackingStep(DirectTracker::Impl& m, const DirectTrackerOptions& o, TimeNs t_ns)
      : m_(m), o_(o), t_ns_(t_ns) {}

  TrackResult run() {
    if (!m_.has_ref || !m_.has_prev) return start_sequence();
    const SE3 T_world_pred = predict();
    const SE3 T_ref_guess = m_.T_world_ref.inverse() * T_world_pred;
    AlignOutcome a = AlignRunner::align_with_fallback(m_, o_, T_ref_guess.inverse());
    const bool fallback = a.result.geometric_fallback;
    TrackResult result = a.result;
    result.t_ns = t_ns_;
    if (fallback && result.ok() && o_.fallback.rotation_from_previous_frame) {
      refine_fallback_rotation(a, result);
    }
    result.ref_t_ns = m_.ref_t_ns;
    if (result.ok()) {
      accept(a.T_cur_ref.inverse(), fallback, result);
    } else {
      restart(T_world_pred, result);
    }
    m_.dt_prev = dt_;
    m_.t_prev = t_ns_;
    m_.T_world_prev = result.T_world_cam;
    return result;
  }

 private:
  // This frame becomes the reference. Where the fallback's rotation already built its finest
  // levels (current_ref), they are taken as they are and only the coarser ones are built.
  void build_reference() {
    int first_level = o_.pyramid.finest_level;
    if (m_.current_ref_levels > first_level) {
      std::swap(m_.ref, m_.current_ref);
      first_level = m_.current_ref_levels;
      m_.current_ref_levels = 0;
    }
    TrackerAccess::build_reference(m_, o_, m_.level_cameras, first_level);
  }

  // The first frame (or the first after a reset) defines the world and is the keyframe.
  TrackResult start_sequence() {
    TrackResult result;
    result.t_ns = t_ns_;
    m_.rs_ref_rectified = m_.rs_frame_rectified;
    build_reference();
    m_.ref_t_ns = t_ns_;
    m_.T_world_ref = SE3();
    m_.T_world_prev = SE3();
    m_.t_prev = t_ns_;
    m_.has_prev = true;
    m_.has_velocity = false;
    result.converged = true;
    result.ref_t_ns = t_ns_;
    result.new_keyframe = true;
    result.inlier_ratio = 1.0;
    result.overlap = 1.0;
    result.points = m_.ref[static_cast<std::size_t>(o_.pyramid.finest_level)].count;
    result.covariance.setZero();
    if (result.points < o_.health.min_points) {
      // No alignment ran: the ratios of a frame that cannot even be a reference are unknown.
      result.inlier_ratio = result.overlap = std::numeric_limits<double>::quiet_NaN();
      result.failure = TrackFailure::kTooFewPoints;
      result.failure_detail = "first frame has " + std::to_string(result.points) +
                              " usable points: the next frame starts again";
      m_.has_prev = false;
    }
    return result;
  }

  // Constant-velocity prediction, scaled to this frame's time step.
  SE3 predict() {
    SE3 T_world_pred = m_.T_world_prev;
    dt_ = t_ns_ - m_.t_prev;
    if (o_.keyframes.constant_velocity_prior && m_.has_velocity && m_.dt_prev > 0 && dt_ > 0) {
      const double scale =
          std::clamp(static_cast<double>(dt_) / static_cast<double>(m_.dt_prev), 0.0, 3.0);
      T_world_pred = m_.T_world_prev * SE3::exp(scale * m_.velocity.log());
    }
    return T_world_pred;
  }

  // The fallback's rotation from the previous frame (docs/odometry.md, "The fallback's rotation
  // from the previous frame"); the keyframe alignment's translation is kept.
  void refine_fallback_rotation(AlignOutcome& a, TrackResult& result) {
    const SE3 T_prev_cur_guess = m_.T_world_prev.inverse() * m_.T_world_ref * a.T_cur_ref.inverse();
    const std::optional<SE3> T_prev_cur = AlignRunner::align_previous_to_current(
        m_, o_, m_.level_cameras, T_prev_cur_guess, result.iterations);
    if (T_prev_cur) {
      const SE3 refined(T_prev_cur->so3(), T_prev_cur_guess.translation());
      a.T_cur_ref = (m_.T_world_ref.inverse() * m_.T_world_prev * refined).inverse();
      result.fallback_rotation_from_previous = true;
    }
  }

  // A tracked frame: its pose, the motion model, and a new keyframe where it leaves the old.
  void accept(const SE3& T_ref_cur, bool fallback, TrackResult& result) {
    result.T_ref_cur = T_ref_cur;
    result.T_world_cam = m_.T_world_ref * T_ref_cur;
    const bool rs_restart = rolling_shutter_restart();
    const bool switch_kf = rs_restart || leaves_keyframe(T_ref_cur, fallback, result);
    m_.velocity = m_.T_world_prev.inverse() * result.T_world_cam;
    m_.has_velocity = true;
    if (!switch_kf) return;
    if (rs_restart) {
      m_.rectify_rolling_shutter(m_.velocity.so3().log() / ns_to_s(dt_), o_);
      m_.rs_frame_rectified = true;
    }
    m_.rs_ref_rectified = m_.rs_frame_rectified;
    build_reference();
    m_.T_world_ref = result.T_world_cam;
    m_.ref_t_ns = t_ns_;
    result.new_keyframe = true;
  }

  // Rolling shutter: a keyframe taken before any rate was known (the first frame, or after a
  // failure) is not rectified, unlike the frames that follow it; so the first frame whose motion
  // is estimated is rectified with its own rate and becomes the keyframe.
  [[nodiscard]] bool rolling_shutter_restart() const {
    return m_.rolling_shutter.has_value() && !m_.rs_ref_rectified && !m_.rs_frame_rectified &&
           dt_ > 0;
  }

  // Whether the frame should replace the keyframe: it overlaps or agrees with it too little, or
  // moved too far from it.
  [[nodiscard]] bool leaves_keyframe(const SE3& T_ref_cur, bool fallback,
                                     const TrackResult& result) const {
    const ReferenceLevel& L = m_.ref[static_cast<std::size_t>(o_.pyramid.finest_level)];
    // A frame whose images agree with the keyframe's only on a coarser level (the fallback's
    // photometric check) is blurred unlike it: the next frames, blurred alike, are aligned to it
    // (as to a frame that failed).
    const bool blurred = fallback && result.photometric_level > o_.pyramid.finest_level;
    return blurred || !o_.keyframes.enabled || result.overlap < o_.keyframes.min_overlap ||
           rotation_angle_deg(T_ref_cur) > o_.keyframes.max_rotation_deg ||
           T_ref_cur.translation().norm() > o_.keyframes.max_translation_rel * L.median_depth;
  }

  // Report the prediction, and start again from this frame: it becomes the reference.
  void restart(const SE3& T_world_pred, TrackResult& result) {
    result.T_world_cam = T_world_pred;
    result.T_ref_cur = m_.T_world_ref.inverse() * T_world_pred;
    m_.rs_ref_rectified = m_.rs_frame_rectified;
    build_reference();
    m_.T_world_ref = T_world_pred;
    m_.ref_t_ns = t_ns_;
    m_.has_velocity = false;
    result.new_keyframe = true;
  }

  DirectTracker::Impl& m_;
  const DirectTrackerOptions& o_;
  const TimeNs t_ns_;
  TimeNs dt_ = 0;
};

}  // namespace

TrackResult DirectTracker::track_prepared(TimeNs t_ns) {
  return TrackingStep(*impl_, options_, t_ns).run();
}

template <typename Frame>
TrackResult DirectTracker::align_frames(const Frame& reference, const Frame& current,
                                        const SE3& T_ref_cur_guess) {
  Impl& m = *impl_;
  reset();
  for (const Frame* f : {&reference, &current}) {
    std::string bad = check_input_kind(disparity_input_, std::is_same_v<Frame, DisparityFrame>);
    if (bad.empty()) bad = check_frame(*f, camera_);
    if (!bad.empty()) return invalid_input(current, bad, SE3());
  }
  prepare_frame(m, reference, options_);
  TrackerAccess::build_reference(m, options_, impl_->level_cameras);
  prepare_frame(m, current, options_);
  return align_prepared_pair(T_ref_cur_guess, reference.t_ns, current.t_ns);
}

TrackResult DirectTracker::align_pair(const RgbdFrame& reference, const RgbdFrame& current,
                                      const SE3& T_ref_cur_guess) {
  return align_frames(reference, current, T_ref_cur_guess);
}

TrackResult DirectTracker::align_pair(const DisparityFrame& reference,
                                      const DisparityFrame& current, const SE3& T_ref_cur_guess) {
  return align_frames(reference, current, T_ref_cur_guess);
}

TrackResult DirectTracker::align_prepared_pair(const SE3& T_ref_cur_guess, TimeNs ref_t_ns,
                                               TimeNs t_ns) {
  Impl& m = *impl_;
  AlignOutcome a = AlignRunner::align_with_fallback(m, options_, T_ref_cur_guess.inverse());
  TrackResult result = a.result;
  result.t_ns = t_ns;
  result.ref_t_ns = ref_t_ns;
  result.T_ref_cur = a.T_cur_ref.inverse();
  result.T_world_cam = result.T_ref_cur;
  reset();
  return result;
}

}  // namespace kestrel::odometry
