// Light sources of the renderer. Shading is Lambertian and view-independent, so that rendered
// frames obey brightness constancy: radiance = albedo * texture * (ambient + sum of lights).
// A light only answers "how much light reaches this surface point", which is also the hook for
// a projector (a pinhole light casting a pattern image, sim/projector_light.hpp): it gets the
// point, its normal and the scene (for shadow rays) and returns a colour.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/sim/texture.hpp"

namespace kestrel::sim {

class Scene;

/// A visible surface point handed to the lights.
struct SurfacePoint {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  /// Unit normal on the side the camera sees.
  Eigen::Vector3d n_world = Eigen::Vector3d::UnitZ();
  int primitive = -1;  ///< index into Scene::primitives()
};

/// What a light may need besides the point: the scene (for shadow rays) and the pose of the
/// camera being rendered (a light mounted on the camera rig moves with it).
struct ShadingContext {
  const Scene& scene;
  SE3 T_world_cam;
};

class LightSource {
 public:
  LightSource() = default;
  LightSource(const LightSource&) = default;
  LightSource& operator=(const LightSource&) = default;
  LightSource(LightSource&&) = default;
  LightSource& operator=(LightSource&&) = default;
  virtual ~LightSource() = default;

  /// Irradiance factor at the point, per channel (BGR): it is added to the ambient term and
  /// the sum multiplies the surface colour. 0 where the point is unlit. Must be thread-safe
  /// (const, no hidden state) and deterministic.
  [[nodiscard]] virtual ColorBgr illuminate(const SurfacePoint& point,
                                            const ShadingContext& context) const = 0;
  /// Adds illuminate() of each point to `irradiance` (same length): the renderer calls this
  /// once per image row. The default loops over illuminate(); lights override it for speed.
  virtual void accumulate(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance,
                          const ShadingContext& context) const;
  [[nodiscard]] virtual std::string describe() const = 0;
};

/// An isotropic point light with a soft inverse-square falloff:
/// E = intensity * max(0, n . l) / (1 + (d / falloff_m)^2).
class PointLight final : public LightSource {
 public:
  PointLight(const Eigen::Vector3d& p_world, const ColorBgr& intensity, double falloff_m,
             bool cast_shadows = false);
  [[nodiscard]] ColorBgr illuminate(const SurfacePoint& point,
                                    const ShadingContext& context) const override;
  void accumulate(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance,
                  const ShadingContext& context) const override;
  [[nodiscard]] std::string describe() const override;

 private:
  Eigen::Vector3d p_world_;
  ColorBgr intensity_;
  double inv_falloff2_;
  bool cast_shadows_;
};

/// A distant light (the sun through a window): E = intensity * max(0, n . -direction).
class DirectionalLight final : public LightSource {
 public:
  DirectionalLight(const Eigen::Vector3d& direction_world, const ColorBgr& intensity);
  [[nodiscard]] ColorBgr illuminate(const SurfacePoint& point,
                                    const ShadingContext& context) const override;
  [[nodiscard]] std::string describe() const override;

 private:
  Eigen::Vector3d to_light_world_;  // unit, towards the light
  ColorBgr intensity_;
};

}  // namespace kestrel::sim
