// Ray-cast renderer of a Scene: exact RGB-D frames and rectified stereo pairs for any pose and
// pinhole intrinsics. Depth is the exact intersection of each pixel-centre ray (pixel (u, v)
// at integer coordinates, PinholeCamera::unproject without distortion) with the nearest face;
// colour is prefiltered (mip-mapped textures, supersampled primitive edges) so that images are
// smooth enough for direct odometry. Algorithm: docs/simulation.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/sim/scene.hpp"
#include "kestrel/sim/sensor_noise.hpp"

namespace kestrel::sim {

struct RenderOptions {
  /// Surfaces nearer than this (Z, metres) are not drawn: the camera sees through them.
  double near_m = 0.05;
  /// Surfaces farther than this (Z) are not drawn (background: black, no depth).
  double far_m = 1000.0;
  /// Pixels on a boundary between primitives (or faces, or the background) get k x k colour
  /// samples averaged (anti-aliased silhouettes); depth stays that of the pixel-centre ray.
  /// 1 = off.
  int edge_supersampling = 3;
  /// Trilinear mip-mapped texture lookup (no aliasing on distant or grazing surfaces); off:
  /// bilinear on the full-resolution texture.
  bool mipmapping = true;
  /// Sensor noise applied to every rendered frame (off by default).
  SensorNoiseOptions noise;

  template <typename V>
  void visit_fields(V&& v) {
    v("near_m", near_m);
    v("far_m", far_m);
    v("edge_supersampling", edge_supersampling);
    v("mipmapping", mipmapping);
    v("noise", noise);
  }

  /// Throws std::invalid_argument for inconsistent values.
  void validate() const;
  [[nodiscard]] std::string describe() const;
  /// The YAML fields, as load_yaml() reads them (the noise as a nested map).
  [[nodiscard]] std::string to_yaml() const;
  /// YAML map with any of near_m, far_m, edge_supersampling, mipmapping and a `noise` map
  /// (SensorNoiseOptions fields). Errors name the file and field.
  static RenderOptions load_yaml(const std::filesystem::path& path);
};

/// Value of depth_m / disparity_px where there is none.
inline constexpr float kNoDepth = 0.0F;

/// One rendered view. Buffers are reused across calls (no allocation once sized).
struct RenderedFrame {
  cv::Mat color_bgr;     ///< CV_8UC3, as cv::imwrite expects
  cv::Mat gray;          ///< CV_32F, I = (R + G + B) / 3 in grey levels [0, 255] (thesis
                         ///< eq. 3.22), from the unrounded colour
  cv::Mat depth_m;       ///< CV_32F, Z along the optical axis (with sensor noise, if any);
                         ///< kNoDepth where none
  cv::Mat primitive_id;  ///< CV_32S, index into Scene::primitives() hit by the centre ray; -1
};

class Renderer {
 public:
  /// Throws std::invalid_argument if the camera has lens distortion (render the
  /// distortion-free camera: camera.without_distortion()) or the options are invalid.
  explicit Renderer(const PinholeCamera& camera, const RenderOptions& options = {},
                    std::uint64_t seed = 1);

  [[nodiscard]] const PinholeCamera& camera() const { return camera_; }
  [[nodiscard]] const RenderOptions& options() const { return options_; }
  /// A light attached to the camera rig (e.g. a projector): evaluated after the scene's
  /// lights, with the pose of the camera being rendered in its ShadingContext.
  void add_rig_light(std::shared_ptr<const LightSource> light);
  /// Restarts the noise generator.
  void reseed(std::uint64_t seed) { noise_.reseed(seed); }
  /// Restarts the noise generator of the view without the rig lights (render()'s
  /// `without_rig_lights`; seeded with the renderer's seed + 1 until then).
  void reseed_without_rig_lights(std::uint64_t seed) { rig_free_noise_.reseed(seed); }

  /// Renders the scene seen from T_world_cam (the optical frame: x right, y down, z forward).
  /// With `without_rig_lights`, the same pass also gives the view lit by the scene's lights
  /// only (what a camera blind to the rig's projector takes: the flight's tracking view), with
  /// its own noise generator: exactly the frame a renderer without the rig lights would give,
  /// for the cost of one multiply per pixel and the noise instead of a second render.
  void render(const Scene& scene, const SE3& T_world_cam, RenderedFrame& frame,
              RenderedFrame* without_rig_lights = nullptr);
  [[nodiscard]] RenderedFrame render(const Scene& scene, const SE3& T_world_cam);

  /// Depth of the last render before noise (CV_32F, kNoDepth where nothing was hit).
  [[nodiscard]] const cv::Mat& exact_depth_m() const { return exact_depth_; }
  /// Pixels that were supersampled in the last render (statistics for benchmarks).
  [[nodiscard]] std::size_t edge_pixels() const { return edge_pixels_; }

  /// Per-face set-up of the current frame (camera-frame plane coefficients); internal.
  struct FaceSetup {
    // 1/Z = iz0 + izu u + izv v; s = Z (s0 + su u + sv v) - s_off; t likewise.
    double iz0 = 0, izu = 0, izv = 0;
    double s0 = 0, su = 0, sv = 0, s_off = 0;
    double t0 = 0, tu = 0, tv = 0, t_off = 0;
    double extent_s = 0, extent_t = 0;  // face size in s and t, metres
    double d_cam = 0;                   // plane offset in the camera frame (n_cam . p = d_cam)
    bool bounded = false;
    bool visible = false;
    int u_min = 0, u_max = -1, v_min = 0, v_max = -1;  // pixel bounding box, inclusive
    Eigen::Vector3d n_world_facing = Eigen::Vector3d::UnitZ();
    double inv_texel2 = 1.0;  // 1 / (level-0 texel size)^2 of the face's texture
    const Face* face = nullptr;
  };

 private:
  void setup_faces(const Scene& scene, const SE3& T_world_cam);
  void rasterize();
  void shade(const Scene& scene, const SE3& T_world_cam, RenderedFrame& frame,
             RenderedFrame* without_rig_lights);
  // The steps of shade(), with one frame's shading constants (renderer.cpp).
  struct Shading;
  void shade_pixel_centres(const Shading& shading);
  void shade_edge_pixels(const Shading& shading);
  /// The k x k supersampled colour of edge pixel (u, v), among the faces around it.
  /// The k x k supersampled colour of edge pixel (u, v), among the faces around it; the
  /// colour without the rig lights in `rig_free` when the shading asks for it.
  [[nodiscard]] ColorBgr supersample_pixel(const Shading& shading, int u, int v,
                                           std::span<const int> faces,
                                           std::span<ColorBgr> sample_color, ColorBgr& rig_free);
  /// Sensor noise on `radiance` (from `noise`), then the output images.
  void write_frame(cv::Mat& radiance, SensorNoise& noise, RenderedFrame& frame);

  PinholeCamera camera_;
  RenderOptions options_;
  SensorNoise noise_;
  SensorNoise rig_free_noise_;  // the view without the rig lights
  std::vector<std::shared_ptr<const LightSource>> rig_lights_;
  std::vector<FaceSetup> setups_;
  std::vector<double> inv_depth_;  // 1/Z of the nearest face per pixel, 0 = none
  std::vector<int> face_id_;       // nearest face per pixel, -1 = none
  cv::Mat radiance_;               // CV_32FC3, linear colour
  cv::Mat rig_free_radiance_;      // the same without the rig lights, when asked for
  cv::Mat exact_depth_;
  cv::Mat cos_incidence_;
  std::vector<SurfacePoint> row_points_;  // lit points of one row, for the lights
  std::vector<ColorBgr> row_irradiance_;  // their ambient + light sums
  std::vector<int> row_columns_;          // their columns
  std::size_t edge_pixels_ = 0;
};

/// A rendered rectified stereo pair with the true disparity of the left view.
struct StereoFrame {
  RenderedFrame left;
  RenderedFrame right;
  cv::Mat disparity_px;  ///< CV_32F, left view: d = uL - uR = B f / Z (exact); kNoDepth where none
};

/// Renders both views of a RectifiedStereo: the right camera is the left one translated by
/// +baseline along its x axis (T_world_right = T_world_left * (I, [B, 0, 0])).
class StereoRenderer {
 public:
  /// Throws std::invalid_argument for an invalid rig. The two views draw their noise from
  /// independent generators derived from `seed`.
  explicit StereoRenderer(const RectifiedStereo& rig, const RenderOptions& options = {},
                          std::uint64_t seed = 1);

  [[nodiscard]] const RectifiedStereo& rig() const { return rig_; }
  /// T_left_right: the right camera in the left camera's frame.
  [[nodiscard]] SE3 T_left_right() const;
  /// A light on the rig (both views see it).
  void add_rig_light(const std::shared_ptr<const LightSource>& light);

  /// With `left_without_rig_lights`, the left renderer also gives its view without the rig
  /// lights (Renderer::render()).
  void render(const Scene& scene, const SE3& T_world_left, StereoFrame& frame,
              RenderedFrame* left_without_rig_lights = nullptr);
  /// Seeds the noise of the left view without the rig lights.
  void reseed_left_without_rig_lights(std::uint64_t seed) { left_.reseed_without_rig_lights(seed); }
  [[nodiscard]] const Renderer& left_renderer() const { return left_; }
  [[nodiscard]] const Renderer& right_renderer() const { return right_; }

 private:
  RectifiedStereo rig_;
  Renderer left_;
  Renderer right_;
};

}  // namespace kestrel::sim
