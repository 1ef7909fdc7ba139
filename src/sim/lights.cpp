// Point and directional lights (Lambertian, view-independent) and the catalogue helper.
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "kestrel/sim/catalogue.hpp"
#include "kestrel/sim/light.hpp"
#include "kestrel/sim/scene.hpp"

namespace kestrel::sim {

std::string catalogue_names(const std::vector<CatalogueEntry>& catalogue) {
  std::string out;
  for (const auto& e : catalogue) {
    if (!out.empty()) out += ", ";
    out += e.name;
  }
  return out;
}

void LightSource::accumulate(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance,
                             const ShadingContext& context) const {
  for (std::size_t i = 0; i < points.size(); ++i) irradiance[i] += illuminate(points[i], context);
}

PointLight::PointLight(const Eigen::Vector3d& p_world, const ColorBgr& intensity, double falloff_m,
                       bool cast_shadows)
    : p_world_(p_world),
      intensity_(intensity),
      inv_falloff2_(1.0 / (falloff_m * falloff_m)),
      cast_shadows_(cast_shadows) {
  if (!(falloff_m > 0.0)) throw std::invalid_argument("PointLight: falloff must be positive");
}

ColorBgr PointLight::illuminate(const SurfacePoint& point, const ShadingContext& context) const {
  const Eigen::Vector3d to_light = p_world_ - point.p_world;
  const double d2 = to_light.squaredNorm();
  const double cos_theta = point.n_world.dot(to_light) / std::sqrt(d2);
  if (!(cos_theta > 0.0)) return {0.0F, 0.0F, 0.0F};
  if (cast_shadows_ && context.scene.occluded(point.p_world, p_world_)) return {0.0F, 0.0F, 0.0F};
  return intensity_ * static_cast<float>(cos_theta / (1.0 + d2 * inv_falloff2_));
}

void PointLight::accumulate(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance,
                            const ShadingContext& context) const {
  if (cast_shadows_) {
    LightSource::accumulate(points, irradiance, context);
    return;
  }
  // The same formula as illuminate(), without the per-point call.
  const double lx = p_world_.x(), ly = p_world_.y(), lz = p_world_.z();
  const auto k = static_cast<float>(inv_falloff2_);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SurfacePoint& p = points[i];
    const double dx = lx - p.p_world.x(), dy = ly - p.p_world.y(), dz = lz - p.p_world.z();
    const double n_dot = p.n_world.x() * dx + p.n_world.y() * dy + p.n_world.z() * dz;
    if (!(n_dot > 0.0)) continue;
    // Single precision from here: an irradiance needs no more, and it halves the cost.
    const auto d2 = static_cast<float>(dx * dx + dy * dy + dz * dz);
    const float e = static_cast<float>(n_dot) / (std::sqrt(d2) * (1.0F + d2 * k));
    irradiance[i] += intensity_ * e;
  }
}

std::string PointLight::describe() const {
  std::ostringstream os;
  os << "point light at (" << p_world_.x() << ", " << p_world_.y() << ", " << p_world_.z()
     << ") intensity " << intensity_[2] << "/" << intensity_[1] << "/" << intensity_[0]
     << " (RGB) falloff " << 1.0 / std::sqrt(inv_falloff2_) << " m"
     << (cast_shadows_ ? ", shadows" : "");
  return os.str();
}

DirectionalLight::DirectionalLight(const Eigen::Vector3d& direction_world,
                                   const ColorBgr& intensity)
    : to_light_world_(-direction_world.normalized()), intensity_(intensity) {
  if (!(direction_world.norm() > 0.0)) {
    throw std::invalid_argument("DirectionalLight: direction must be non-zero");
  }
}

ColorBgr DirectionalLight::illuminate(const SurfacePoint& point,
                                      const ShadingContext& /*context*/) const {
  const double cos_theta = point.n_world.dot(to_light_world_);
  if (!(cos_theta > 0.0)) return {0.0F, 0.0F, 0.0F};
  return intensity_ * static_cast<float>(cos_theta);
}

std::string DirectionalLight::describe() const {
  std::ostringstream os;
  os << "directional light towards (" << -to_light_world_.x() << ", " << -to_light_world_.y()
     << ", " << -to_light_world_.z() << ") intensity " << intensity_[2] << "/" << intensity_[1]
     << "/" << intensity_[0] << " (RGB)";
  return os.str();
}

}  // namespace kestrel::sim
