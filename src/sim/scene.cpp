// Scene construction (primitives to planar faces) and the slow-path ray query.
#include "kestrel/sim/scene.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace kestrel::sim {

namespace {

void check_material(const Material& m) {
  if (!m.texture) throw std::invalid_argument("Scene: a material needs a texture");
}

Face make_face(const SE3& T_world_local, const Eigen::Vector3d& origin_local,
               const Eigen::Vector3d& s_local, const Eigen::Vector3d& t_local, double size_s,
               double size_t, bool one_sided, int primitive, const Material& material) {
  Face f;
  const Eigen::Matrix3d R = T_world_local.rotation_matrix();
  f.origin_world = T_world_local * origin_local;
  f.axis_s = R * s_local;
  f.axis_t = R * t_local;
  f.normal = f.axis_s.cross(f.axis_t);
  f.size_s_m = size_s;
  f.size_t_m = size_t;
  f.one_sided = one_sided;
  f.primitive = primitive;
  f.material = material;
  return f;
}

}  // namespace

PlanarRect PlanarRect::from_corner(const Eigen::Vector3d& origin, const Eigen::Vector3d& s_dir,
                                   const Eigen::Vector3d& t_dir, double width_m, double height_m,
                                   Material material) {
  const Eigen::Vector3d s = s_dir.normalized();
  const Eigen::Vector3d t_perp = t_dir - t_dir.dot(s) * s;
  if (!(s_dir.norm() > 0.0) || !(t_perp.norm() > 1e-12 * t_dir.norm()) || !s.allFinite()) {
    throw std::invalid_argument("PlanarRect::from_corner: degenerate edge directions");
  }
  const Eigen::Vector3d t = t_perp.normalized();
  Eigen::Matrix3d R;
  R.col(0) = s;
  R.col(1) = t;
  R.col(2) = s.cross(t);
  return {SE3(SO3::from_matrix(R), origin), width_m, height_m, std::move(material)};
}

Scene::Scene(std::string name, std::string description)
    : name_(std::move(name)), description_(std::move(description)) {}

int Scene::add(const Primitive& primitive) {
  const int index = static_cast<int>(primitives_.size());
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d ey = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
  if (const auto* rect = std::get_if<PlanarRect>(&primitive)) {
    check_material(rect->material);
    if (!(rect->width_m > 0.0) || !(rect->height_m > 0.0)) {
      throw std::invalid_argument("Scene: a rectangle needs a positive width and height");
    }
    faces_.push_back(make_face(rect->T_world_rect, zero, ex, ey, rect->width_m, rect->height_m,
                               false, index, rect->material));
  } else if (const auto* plane = std::get_if<InfinitePlane>(&primitive)) {
    check_material(plane->material);
    const double inf = std::numeric_limits<double>::infinity();
    faces_.push_back(
        make_face(plane->T_world_plane, zero, ex, ey, inf, inf, false, index, plane->material));
  } else {
    const auto& box = std::get<OrientedBox>(primitive);
    check_material(box.material);
    const Eigen::Vector3d& h = box.half_extents_m;
    if (!(h.minCoeff() > 0.0)) throw std::invalid_argument("Scene: box extents must be positive");
    const SE3& T = box.T_world_box;
    const Material& m = box.material;
    // Six outward faces; each (s, t) frame starts at a corner and s x t is the outward normal.
    faces_.push_back(
        make_face(T, {h.x(), -h.y(), -h.z()}, ey, ez, 2 * h.y(), 2 * h.z(), true, index, m));
    faces_.push_back(
        make_face(T, {-h.x(), h.y(), -h.z()}, -ey, ez, 2 * h.y(), 2 * h.z(), true, index, m));
    faces_.push_back(
        make_face(T, {h.x(), h.y(), -h.z()}, -ex, ez, 2 * h.x(), 2 * h.z(), true, index, m));
    faces_.push_back(
        make_face(T, {-h.x(), -h.y(), -h.z()}, ex, ez, 2 * h.x(), 2 * h.z(), true, index, m));
    faces_.push_back(
        make_face(T, {-h.x(), -h.y(), h.z()}, ex, ey, 2 * h.x(), 2 * h.y(), true, index, m));
    faces_.push_back(
        make_face(T, {-h.x(), h.y(), -h.z()}, ex, -ey, 2 * h.x(), 2 * h.y(), true, index, m));
  }
  primitives_.push_back(primitive);
  return index;
}

void Scene::add_light(std::shared_ptr<const LightSource> light) {
  if (!light) throw std::invalid_argument("Scene::add_light: null light");
  lights_.push_back(std::move(light));
}

std::optional<RayHit> Scene::intersect(const Eigen::Vector3d& origin_world,
                                       const Eigen::Vector3d& direction_world, double min_distance,
                                       double max_distance) const {
  const Eigen::Vector3d dir = direction_world.normalized();
  std::optional<RayHit> best;
  double best_d = max_distance;
  for (std::size_t i = 0; i < faces_.size(); ++i) {
    const Face& f = faces_[i];
    const double denom = f.normal.dot(dir);
    if (denom == 0.0 || (f.one_sided && denom > 0.0)) continue;
    const double d = f.normal.dot(f.origin_world - origin_world) / denom;
    if (!(d > min_distance) || d > best_d) continue;
    const Eigen::Vector3d p = origin_world + d * dir;
    const double s = f.axis_s.dot(p - f.origin_world);
    const double t = f.axis_t.dot(p - f.origin_world);
    if (f.bounded() && (s < 0.0 || s > f.size_s_m || t < 0.0 || t > f.size_t_m)) continue;
    best_d = d;
    best = RayHit{d,          p, denom < 0.0 ? f.normal : Eigen::Vector3d(-f.normal),
                  s,          t, static_cast<int>(i),
                  f.primitive};
  }
  return best;
}

bool Scene::occluded(const Eigen::Vector3d& from_world, const Eigen::Vector3d& to_world) const {
  const Eigen::Vector3d d = to_world - from_world;
  const double length = d.norm();
  if (!(length > 0.0)) return false;
  // Margins keep the surfaces at either end from shadowing themselves.
  return intersect(from_world, d, 1e-6, length - 1e-6).has_value();
}

}  // namespace kestrel::sim
