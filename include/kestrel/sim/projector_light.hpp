// The projector of the active-stereo sensor, simulated (thesis 2.3, fig. 2.7): a pinhole light
// source at a calibrated pose beside the stereo pair that casts the pattern image onto the
// scene, with shadows and inverse-square fall-off, and the rendering of active stereo pairs
// (dark room: pattern only; or ambient light + pattern) with their true disparity.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/sim/light.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scene.hpp"

namespace kestrel::sim {

struct ProjectorOptions {
  /// Pose of the projector's optical frame (x right, y down, z forward) in the LEFT camera's
  /// rectified frame. Default: parallel to the cameras, 5 cm to the right and 8 cm above the
  /// left camera (between the two cameras of a ~10 cm rig, as in the thesis' sensor head).
  SE3 T_left_projector = SE3(SO3(), Eigen::Vector3d(0.05, -0.08, 0.0));
  /// Projector resolution (LG PH300: 1280x720); the pattern image must have this size.
  int width = 1280;
  int height = 720;
  /// Horizontal field of view; square pixels, principal point at the image centre. About 100
  /// degrees covers the camera's view from the projector's offset.
  double horizontal_fov_deg = 100.0;
  /// Irradiance factor of a white pattern pixel at `reference_distance_m` and normal incidence
  /// (added to the ambient term, as the renderer's other lights).
  double power = 0.6;
  /// Fall-off: E ~ (reference_distance_m / d)^2, d = distance from the projector centre.
  double reference_distance_m = 3.0;
  /// Lambertian: multiply by cos(angle between the surface normal and the projector ray).
  bool lambertian = true;
  /// Gaussian blur of the pattern (projector defocus), sigma in pattern pixels; 0 = none.
  double blur_sigma_px = 1.0;
  /// Shadows: points that cannot see the projector get no pattern.
  bool shadows = true;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
  /// The projector's pinhole camera (fx = fy = width / 2 / tan(fov / 2), centred).
  [[nodiscard]] PinholeCamera camera() const;
};

/// A pinhole light source casting an image, fixed in the world (it ignores the pose of the
/// camera being rendered, so both views of a stereo pair see the same pattern). A surface
/// point p gets E = power * pattern(project(p)) * (d_ref / d)^2 [* cos], 0 outside the
/// projector image, behind it, or in shadow (Scene::occluded between p and the projector).
class ProjectorLight final : public LightSource {
 public:
  /// `pattern`: CV_8UC3 (BGR) or CV_8UC1 of options.width x options.height. Throws
  /// InputError for an empty pattern or the wrong size, std::invalid_argument for bad options.
  ProjectorLight(const SE3& T_world_projector, const cv::Mat& pattern,
                 const ProjectorOptions& options);

  [[nodiscard]] ColorBgr illuminate(const SurfacePoint& point,
                                    const ShadingContext& context) const override;
  void accumulate(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance,
                  const ShadingContext& context) const override;
  [[nodiscard]] std::string describe() const override;

  [[nodiscard]] const SE3& T_world_projector() const { return T_world_projector_; }
  /// Moves the projector (a projector on a moving rig: once per frame, between renders, never
  /// during one). Keeps the prepared pattern, so a move costs nothing.
  void set_pose(const SE3& T_world_projector);
  [[nodiscard]] const PinholeCamera& camera() const { return camera_; }
  /// The pattern as the light samples it: CV_32FC3 in [0, 1], blurred.
  [[nodiscard]] const cv::Mat& pattern() const { return pattern_; }

 private:
  [[nodiscard]] ColorBgr irradiance(const SurfacePoint& point, const ShadingContext& context) const;
  /// The projector pixel (u, v) of a world point; false behind the projector or outside its
  /// image.
  [[nodiscard]] bool project(const Eigen::Vector3d& p_world, double& u, double& v) const;
  /// A pattern sample that lights nothing (between the pattern's lines).
  [[nodiscard]] static bool is_dark(const cv::Vec3f& sample);
  /// The irradiance at `point` from its pattern sample: fall-off, incidence, shadow.
  [[nodiscard]] ColorBgr light(const SurfacePoint& point, const cv::Vec3f& sample,
                               const ShadingContext& context) const;
  /// The blurred pattern, bilinear, at projector pixel (u, v) inside [-0.5, size - 0.5].
  [[nodiscard]] cv::Vec3f pattern_at(double u, double v) const;

  SE3 T_world_projector_;
  SE3 T_projector_world_;
  Eigen::Matrix3d R_projector_world_;  // T_projector_world_'s rotation, for each lit point
  ProjectorOptions options_;
  PinholeCamera camera_;
  cv::Mat pattern_;
  cv::Mat pattern16_;  // pattern_ as CV_16UC3 (x 65535) for the lookup, a spare row behind
};

enum class ProjectorMode {
  kOff,                ///< passive: the scene's own lights only
  kDarkRoom,           ///< pattern only: no ambient light, the scene's lights off (thesis)
  kAmbientAndPattern,  ///< the scene's lights plus the pattern
};

/// "off", "dark" or "ambient"; throws InputError otherwise.
ProjectorMode parse_projector_mode(const std::string& name);
const char* projector_mode_name(ProjectorMode mode);

/// A copy of `scene` lit for `mode`: with a world-fixed ProjectorLight at
/// T_world_left * T_left_projector (none for kOff); for kDarkRoom, ambient 0 and without the
/// scene's lights.
Scene scene_with_projector(const Scene& scene, const SE3& T_world_left, const cv::Mat& pattern,
                           ProjectorMode mode, const ProjectorOptions& options);
/// The same with a given light (for a projector that moves with the rig: keep the pointer and
/// ProjectorLight::set_pose() it before each frame). For kOff the light is not added.
Scene scene_with_projector(const Scene& scene, const std::shared_ptr<const ProjectorLight>& light,
                           ProjectorMode mode);

/// Renders a rectified stereo pair of `scene` from T_world_left lit as `mode` says, with the
/// sensor noise of `render_options`; the frame holds left, right and the true left disparity.
/// `seed` seeds the noise: the same seed gives identical images.
StereoFrame render_active_stereo(const Scene& scene, const RectifiedStereo& rig,
                                 const SE3& T_world_left, const cv::Mat& pattern,
                                 ProjectorMode mode, const ProjectorOptions& options = {},
                                 const RenderOptions& render_options = {}, std::uint64_t seed = 1);

/// Left pixels whose surface point both cameras see (CV_8U, 255 = yes): the truth has a
/// disparity d and the right view's depth at u - d (nearest pixel) matches the left depth
/// within `relative_tolerance`. Needs exact depth (no depth noise) in the frame.
cv::Mat covisible_mask(const StereoFrame& frame, double relative_tolerance = 0.02);

}  // namespace kestrel::sim
