// A synthetic 3-D scene: textured planar rectangles, infinite planes and oriented boxes, with
// lights. A value type: primitives are plain data; textures and lights are immutable and
// shared, so copying a scene is cheap and copies never interfere.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/sim/light.hpp"
#include "kestrel/sim/texture.hpp"

namespace kestrel::sim {

/// What a surface looks like: colour = albedo * texture(s, t), per channel.
struct Material {
  std::shared_ptr<const Texture> texture;  ///< never null in a Scene (checked on add)
  ColorBgr albedo{1.0F, 1.0F, 1.0F};
};

/// A finite rectangle: the points T_world_rect * (x, y, 0) with x in [0, width_m] and y in
/// [0, height_m]. Texture coordinates are (s, t) = (x, y) in metres. Visible from both sides.
struct PlanarRect {
  SE3 T_world_rect;
  double width_m = 1.0;
  double height_m = 1.0;
  Material material;

  /// The rectangle with corner `origin`, edges along unit vectors s_dir (width) and t_dir
  /// (height, made orthogonal to s_dir); its normal is s_dir x t_dir.
  static PlanarRect from_corner(const Eigen::Vector3d& origin, const Eigen::Vector3d& s_dir,
                                const Eigen::Vector3d& t_dir, double width_m, double height_m,
                                Material material);
};

/// The infinite plane z = 0 of frame T_world_plane; (s, t) = (x, y). Visible from both sides.
struct InfinitePlane {
  SE3 T_world_plane;
  Material material;
};

/// A solid box centred on T_world_box with half extents along its axes. Only its outside is
/// drawn (faces seen from within are culled). Each face is textured in its own metric
/// coordinates, starting at one of its corners.
struct OrientedBox {
  SE3 T_world_box;
  Eigen::Vector3d half_extents_m = Eigen::Vector3d::Constant(0.5);
  Material material;
};

using Primitive = std::variant<PlanarRect, InfinitePlane, OrientedBox>;

/// A planar polygon the renderer draws: every primitive becomes one face (rect, plane) or
/// six (box). Points are origin + s * axis_s + t * axis_t with s in [0, size_s_m], t in
/// [0, size_t_m] (infinite for planes).
struct Face {
  Eigen::Vector3d origin_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_s = Eigen::Vector3d::UnitX();  ///< unit
  Eigen::Vector3d axis_t = Eigen::Vector3d::UnitY();  ///< unit, orthogonal to axis_s
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< axis_s x axis_t (outward on boxes)
  double size_s_m = std::numeric_limits<double>::infinity();
  double size_t_m = std::numeric_limits<double>::infinity();
  bool one_sided = false;  ///< true for box faces: invisible from behind
  int primitive = -1;      ///< index into Scene::primitives()
  Material material;

  [[nodiscard]] bool bounded() const { return std::isfinite(size_s_m); }
};

/// The nearest intersection of a ray with the scene.
struct RayHit {
  double distance = 0.0;  ///< along the (unit) ray direction, metres
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d n_world = Eigen::Vector3d::UnitZ();  ///< facing the ray's origin
  double s_m = 0.0, t_m = 0.0;                         ///< texture coordinates on the face
  int face = -1;
  int primitive = -1;
};

class Scene {
 public:
  explicit Scene(std::string name = "custom", std::string description = {});

  /// Adds a primitive and returns its index. Throws std::invalid_argument for a material
  /// without texture or a non-positive size.
  int add(const Primitive& primitive);
  void add_light(std::shared_ptr<const LightSource> light);
  /// Light that reaches every surface regardless of orientation (default 1: no lights needed).
  void set_ambient(float ambient) { ambient_ = ambient; }
  /// A pose for the body (trajectories start here; z-up world, body x forward, z up).
  void set_T_world_start(const SE3& T_world_start) { T_world_start_ = T_world_start; }

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const std::string& description() const { return description_; }
  [[nodiscard]] const std::vector<Primitive>& primitives() const { return primitives_; }
  [[nodiscard]] const std::vector<Face>& faces() const { return faces_; }
  [[nodiscard]] const std::vector<std::shared_ptr<const LightSource>>& lights() const {
    return lights_;
  }
  [[nodiscard]] float ambient() const { return ambient_; }
  [[nodiscard]] const SE3& T_world_start() const { return T_world_start_; }

  /// Nearest hit at origin + d * direction / |direction| for d in (min_distance,
  /// max_distance], metres. Slow path (loops over all faces): for shadow rays, projectors
  /// and tests, not per pixel.
  [[nodiscard]] std::optional<RayHit> intersect(
      const Eigen::Vector3d& origin_world, const Eigen::Vector3d& direction_world,
      double min_distance = 1e-9,
      double max_distance = std::numeric_limits<double>::infinity()) const;
  /// True if anything lies strictly between the two points (shadow test).
  [[nodiscard]] bool occluded(const Eigen::Vector3d& from_world,
                              const Eigen::Vector3d& to_world) const;

 private:
  std::string name_;
  std::string description_;
  std::vector<Primitive> primitives_;
  std::vector<Face> faces_;
  std::vector<std::shared_ptr<const LightSource>> lights_;
  float ambient_ = 1.0F;
  SE3 T_world_start_;
};

}  // namespace kestrel::sim
