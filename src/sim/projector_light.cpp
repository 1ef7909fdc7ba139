// The projector light (pinhole light casting the pattern, with shadows and fall-off) and the
// rendering of active stereo pairs; see docs/stereo.md.
#include "kestrel/sim/projector_light.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {

void ProjectorOptions::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("ProjectorOptions: " + what);
  };
  if (width < 2 || height < 2) {
    fail("width and height must be >= 2, got " + std::to_string(width) + "x" +
         std::to_string(height));
  }
  if (!(horizontal_fov_deg > 0.0 && horizontal_fov_deg < 170.0)) {
    fail("horizontal_fov_deg must lie in (0, 170), got " + std::to_string(horizontal_fov_deg));
  }
  if (!(power >= 0.0 && std::isfinite(power))) fail("power must be finite and >= 0");
  if (!(reference_distance_m > 0.0 && std::isfinite(reference_distance_m))) {
    fail("reference_distance_m must be finite and > 0");
  }
  if (!(blur_sigma_px >= 0.0 && blur_sigma_px <= 50.0)) fail("blur_sigma_px must lie in [0, 50]");
  if (!T_left_projector.translation().allFinite()) fail("T_left_projector must be finite");
}

std::string ProjectorOptions::describe() const {
  std::ostringstream os;
  const Eigen::Vector3d& t = T_left_projector.translation();
  os << "projector " << width << "x" << height << ", hfov " << horizontal_fov_deg << " deg, at ("
     << t.x() << ", " << t.y() << ", " << t.z() << ") m from the left camera, power " << power
     << " at " << reference_distance_m << " m, 1/d^2" << (lambertian ? ", Lambertian" : "")
     << ", blur " << blur_sigma_px << " px" << (shadows ? ", shadows" : ", no shadows");
  return os.str();
}

PinholeCamera ProjectorOptions::camera() const {
  validate();
  const double half_fov_rad = 0.5 * horizontal_fov_deg * std::numbers::pi / 180.0;
  const double f = 0.5 * static_cast<double>(width) / std::tan(half_fov_rad);
  PinholeIntrinsics k;
  k.fx = k.fy = f;
  // Pixel centres at integer coordinates (as the renderer): the image spans [-0.5, w - 0.5].
  k.cx = 0.5 * static_cast<double>(width - 1);
  k.cy = 0.5 * static_cast<double>(height - 1);
  k.width = width;
  k.height = height;
  return PinholeCamera(k);
}

ProjectorLight::ProjectorLight(const SE3& T_world_projector, const cv::Mat& pattern,
                               const ProjectorOptions& options)
    : T_world_projector_(T_world_projector),
      T_projector_world_(T_world_projector.inverse()),
      options_(options),
      camera_(options.camera()) {
  if (pattern.empty()) throw InputError("projector: empty pattern image");
  if (pattern.cols != options.width || pattern.rows != options.height) {
    throw InputError("projector: the pattern is " + std::to_string(pattern.cols) + "x" +
                     std::to_string(pattern.rows) + ", the projector " +
                     std::to_string(options.width) + "x" + std::to_string(options.height));
  }
  if (pattern.depth() != CV_8U || (pattern.channels() != 1 && pattern.channels() != 3)) {
    throw InputError("projector: the pattern must be 8-bit grey or BGR");
  }
  cv::Mat bgr;
  if (pattern.channels() == 1) {
    cv::cvtColor(pattern, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = pattern;
  }
  bgr.convertTo(pattern_, CV_32FC3, 1.0 / 255.0);
  if (options.blur_sigma_px > 0.0) {
    cv::GaussianBlur(pattern_, pattern_, cv::Size(0, 0), options.blur_sigma_px,
                     options.blur_sigma_px, cv::BORDER_CONSTANT);
  }
  // The lookup's copy, 16 bits a channel (steps of 1.5e-5, far below an 8-bit image's): half
  // the memory of floats. A camera view reads megabytes of a 1280x720 pattern in projector
  // order, so the lookup waited on memory. A spare row follows in the same buffer: each
  // pixel's three channels are loaded as four.
  cv::Mat buffer(pattern_.rows + 1, pattern_.cols, CV_16UC3, cv::Scalar::all(0));
  pattern16_ = buffer.rowRange(0, pattern_.rows);
  pattern_.convertTo(pattern16_, CV_16U, 65535.0);
  set_pose(T_world_projector);
}

void ProjectorLight::set_pose(const SE3& T_world_projector) {
  T_world_projector_ = T_world_projector;
  T_projector_world_ = T_world_projector.inverse();
  R_projector_world_ = T_projector_world_.rotation_matrix();
}

ColorBgr ProjectorLight::illuminate(const SurfacePoint& point,
                                    const ShadingContext& context) const {
  return irradiance(point, context);
}

// The renderer hands a row of points at a time: one call, no per-point dispatch. The points go
// in chunks: all projections first, then the pattern lookups back to back, then the rest. The
// lookups miss the caches; back to back their misses overlap, where between each point's
// arithmetic they waited one after the other.
void ProjectorLight::accumulate(std::span<const SurfacePoint> points,
                                std::span<ColorBgr> irradiance_sum,
                                const ShadingContext& context) const {
  constexpr std::size_t kChunk = 32;
  std::array<double, kChunk> us{}, vs{};
  std::array<std::size_t, kChunk> index{};
  std::array<cv::Vec3f, kChunk> samples;
  for (std::size_t first = 0; first < points.size(); first += kChunk) {
    const std::size_t n = std::min(kChunk, points.size() - first);
    std::size_t lit = 0;  // points that project into the image
    for (std::size_t i = first; i < first + n; ++i) {
      if (project(points[i].p_world, us[lit], vs[lit])) index[lit++] = i;
    }
    for (std::size_t j = 0; j < lit; ++j) samples[j] = pattern_at(us[j], vs[j]);
    for (std::size_t j = 0; j < lit; ++j) {
      if (is_dark(samples[j])) continue;
      const std::size_t i = index[j];
      irradiance_sum[i] += light(points[i], samples[j], context);
    }
  }
}

bool ProjectorLight::project(const Eigen::Vector3d& p_world, double& u, double& v) const {
  const Eigen::Vector3d p = R_projector_world_ * p_world + T_projector_world_.translation();
  if (!(p.z() > 1e-6)) return false;  // behind the projector
  // One division for the projection and one for the distance: this runs for every lit pixel.
  const double inv_z = 1.0 / p.z();
  u = camera_.fx() * p.x() * inv_z + camera_.cx();
  v = camera_.fy() * p.y() * inv_z + camera_.cy();
  // Outside the image [-0.5, size - 0.5]: unlit.
  return u >= -0.5 && v >= -0.5 && u <= options_.width - 0.5 && v <= options_.height - 0.5;
}

bool ProjectorLight::is_dark(const cv::Vec3f& sample) {
  return sample[0] <= 0.0F && sample[1] <= 0.0F && sample[2] <= 0.0F;
}

ColorBgr ProjectorLight::irradiance(const SurfacePoint& point,
                                    const ShadingContext& context) const {
  const ColorBgr dark(0.0F, 0.0F, 0.0F);
  double u = 0.0, v = 0.0;
  if (!project(point.p_world, u, v)) return dark;
  // The pattern first: most points fall between its lines, where nothing else is needed.
  const cv::Vec3f sample = pattern_at(u, v);
  if (is_dark(sample)) return dark;
  return light(point, sample, context);
}

ColorBgr ProjectorLight::light(const SurfacePoint& point, const cv::Vec3f& sample,
                               const ShadingContext& context) const {
  const ColorBgr dark(0.0F, 0.0F, 0.0F);
  const Eigen::Vector3d& c_world = T_world_projector_.translation();
  const Eigen::Vector3d to_projector = c_world - point.p_world;
  const double inv_d = 1.0 / to_projector.norm();
  const double relative = options_.reference_distance_m * inv_d;
  double gain = options_.power * relative * relative;
  if (options_.lambertian) {
    const double cos_theta = point.n_world.dot(to_projector) * inv_d;
    if (!(cos_theta > 0.0)) return dark;
    gain *= cos_theta;
  }
  // The shadow ray last: it is the expensive part (all faces).
  if (options_.shadows && context.scene.occluded(point.p_world, c_world)) return dark;
  return sample * static_cast<float>(gain);
}

namespace {

/// Four floats in one register (GCC and Clang vector extension): a pixel's blue, green, red
/// and one channel of the next pixel, which the arithmetic carries along and the result drops.
using Lanes = float __attribute__((vector_size(16)));

inline Lanes load_pixel(const std::uint16_t* p) {
  // Portable vector extension, no x86 intrinsics (docs/onboard.md: none in src/).
  using Lanes16 = std::uint16_t __attribute__((vector_size(8)));
  Lanes16 v;
  std::memcpy(&v, p, sizeof v);
  return __builtin_convertvector(v, Lanes);
}

}  // namespace

cv::Vec3f ProjectorLight::pattern_at(double u, double v) const {
  // Bilinear sample, edge pixels clamped (the image ends at the half-pixel border).
  const int w = options_.width, h = options_.height;
  const double uc = std::clamp(u, 0.0, static_cast<double>(w - 1));
  const double vc = std::clamp(v, 0.0, static_cast<double>(h - 1));
  const int u0 = std::min(static_cast<int>(uc), w - 2);
  const int v0 = std::min(static_cast<int>(vc), h - 2);
  const auto a = static_cast<float>(uc - u0);
  const auto b = static_cast<float>(vc - v0);
  const auto* r0 = pattern16_.ptr<std::uint16_t>(v0) + 3 * static_cast<std::size_t>(u0);
  const auto* r1 = pattern16_.ptr<std::uint16_t>(v0 + 1) + 3 * static_cast<std::size_t>(u0);
  const Lanes top = load_pixel(r0) * (1.0F - a) + load_pixel(r0 + 3) * a;
  const Lanes bottom = load_pixel(r1) * (1.0F - a) + load_pixel(r1 + 3) * a;
  const Lanes color = (top * (1.0F - b) + bottom * b) * (1.0F / 65535.0F);
  return {color[0], color[1], color[2]};
}

std::string ProjectorLight::describe() const {
  const Eigen::Vector3d& t = T_world_projector_.translation();
  std::ostringstream os;
  os << "projector light at (" << t.x() << ", " << t.y() << ", " << t.z()
     << "): " << options_.describe();
  return os.str();
}

ProjectorMode parse_projector_mode(const std::string& name) {
  if (name == "off" || name == "passive") return ProjectorMode::kOff;
  if (name == "dark") return ProjectorMode::kDarkRoom;
  if (name == "ambient") return ProjectorMode::kAmbientAndPattern;
  throw InputError("projector mode: expected off, dark or ambient, got '" + name + "'");
}

const char* projector_mode_name(ProjectorMode mode) {
  switch (mode) {
    case ProjectorMode::kOff:
      return "off";
    case ProjectorMode::kDarkRoom:
      return "dark";
    case ProjectorMode::kAmbientAndPattern:
      return "ambient";
  }
  return "?";
}

Scene scene_with_projector(const Scene& scene, const std::shared_ptr<const ProjectorLight>& light,
                           ProjectorMode mode) {
  if (mode == ProjectorMode::kOff) return scene;
  Scene lit = scene;
  if (mode == ProjectorMode::kDarkRoom) {
    // The same geometry without the scene's lights (a Scene cannot drop lights: rebuild it).
    lit = Scene(scene.name(), scene.description());
    for (const Primitive& primitive : scene.primitives()) lit.add(primitive);
    lit.set_T_world_start(scene.T_world_start());
    lit.set_ambient(0.0F);
  }
  lit.add_light(light);
  return lit;
}

Scene scene_with_projector(const Scene& scene, const SE3& T_world_left, const cv::Mat& pattern,
                           ProjectorMode mode, const ProjectorOptions& options) {
  if (mode == ProjectorMode::kOff) return scene;
  // World-fixed: each view's ShadingContext carries its own camera pose, which must not move
  // the projector, so the light is placed once from the LEFT camera's pose.
  return scene_with_projector(
      scene,
      std::make_shared<ProjectorLight>(T_world_left * options.T_left_projector, pattern, options),
      mode);
}

StereoFrame render_active_stereo(const Scene& scene, const RectifiedStereo& rig,
                                 const SE3& T_world_left, const cv::Mat& pattern,
                                 ProjectorMode mode, const ProjectorOptions& options,
                                 const RenderOptions& render_options, std::uint64_t seed) {
  const Scene lit = scene_with_projector(scene, T_world_left, pattern, mode, options);
  StereoRenderer renderer(rig, render_options, seed);
  StereoFrame frame;
  renderer.render(lit, T_world_left, frame);
  return frame;
}

cv::Mat covisible_mask(const StereoFrame& frame, double relative_tolerance) {
  const cv::Mat& truth = frame.disparity_px;
  const cv::Mat& z_left = frame.left.depth_m;
  const cv::Mat& z_right = frame.right.depth_m;
  if (truth.empty() || truth.size() != z_left.size() || z_left.size() != z_right.size()) {
    throw std::invalid_argument("covisible_mask: the frame's buffers differ in size");
  }
  cv::Mat mask(truth.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < truth.rows; ++v) {
    const auto* d = truth.ptr<float>(v);
    const auto* zl = z_left.ptr<float>(v);
    const auto* zr = z_right.ptr<float>(v);
    auto* m = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < truth.cols; ++u) {
      if (!(d[u] > 0.0F && std::isfinite(d[u]) && zl[u] > 0.0F)) continue;
      const long ur = std::lround(static_cast<double>(u) - static_cast<double>(d[u]));
      if (ur < 0 || ur >= truth.cols) continue;
      const double z = static_cast<double>(zl[u]);
      if (std::abs(static_cast<double>(zr[ur]) - z) <= relative_tolerance * z) m[u] = 255;
    }
  }
  return mask;
}

}  // namespace kestrel::sim
