// The renderer: per-face plane set-up, a z-buffer pass with exact per-pixel ray-plane
// intersections, then deferred shading (mip-mapped textures, lights, supersampled edges).
//
// For a face with camera-frame plane n.p = d, the ray of pixel (u, v) is r = (x, y, 1) with
// x = (u - cx)/fx, y = (v - cy)/fy, and meets the plane at depth Z = d / (n . r): inverse
// depth is affine in (u, v), and so are Z * s and Z * t for the face's texture coordinates.
// One multiply-add per pixel gives the exact 1/Z of the pixel-centre ray.
#include "kestrel/sim/renderer.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <future>
#include <span>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sim {

namespace {

// Inside test margin: a pixel ray through the shared edge of two faces must not slip
// between them through rounding. 1e-9 m is far below anything a test or a sensor resolves.
constexpr double kEdgeMargin = 1e-9;

std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t x = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// log2(x) for x > 0 to about 1e-4 (exponent bits plus a quartic in the mantissa; no libm
/// call in the per-pixel path). Continuous to 6e-5 across powers of two: no visible mip seams.
inline float fast_log2(float x) {
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const auto exponent = static_cast<float>(static_cast<int>((bits >> 23) & 255U) - 127);
  const float m = std::bit_cast<float>((bits & 0x007FFFFFU) | 0x3F800000U);  // in [1, 2)
  return exponent - 1.7417939F +
         (2.8212026F + (-1.4699568F + (0.44717955F - 0.056570851F * m) * m) * m) * m;
}

/// Clips a convex polygon (camera frame) to z >= near (Sutherland-Hodgman, one plane).
int clip_near(const std::array<Eigen::Vector3d, 4>& in, double near,
              std::array<Eigen::Vector3d, 8>& out) {
  int n = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const Eigen::Vector3d& a = in[i];
    const Eigen::Vector3d& b = in[(i + 1) % in.size()];
    const bool a_in = a.z() >= near;
    const bool b_in = b.z() >= near;
    if (a_in) out[static_cast<std::size_t>(n++)] = a;
    if (a_in != b_in) {
      const double k = (near - a.z()) / (b.z() - a.z());
      out[static_cast<std::size_t>(n++)] = a + k * (b - a);
    }
  }
  return n;
}

/// Whether a 4-neighbour of pixel (u, v) shows a different face (or the background).
inline bool on_face_boundary(const std::vector<int>& face_id, int u, int v, int w, int h) {
  const std::size_t idx =
      static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u);
  const int id = face_id[idx];
  return (u > 0 && face_id[idx - 1] != id) || (u + 1 < w && face_id[idx + 1] != id) ||
         (v > 0 && face_id[idx - static_cast<std::size_t>(w)] != id) ||
         (v + 1 < h && face_id[idx + static_cast<std::size_t>(w)] != id);
}

/// The distinct faces seen in the 3x3 neighbourhood of pixel (u, v), in scan order; returns
/// their number.
std::size_t faces_around(const std::vector<int>& face_id, int u, int v, int w, int h,
                         std::array<int, 9>& faces) {
  std::size_t n = 0;
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      const int uu = u + du, vv = v + dv;
      if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;
      const int c = face_id[static_cast<std::size_t>(vv) * static_cast<std::size_t>(w) +
                            static_cast<std::size_t>(uu)];
      if (c < 0) continue;
      if (std::find(faces.begin(), faces.begin() + n, c) == faces.begin() + n) faces[n++] = c;
    }
  }
  return n;
}

/// The nearest face a ray meets and its inverse depth; face == nullptr: none (background).
struct FaceHit {
  const Renderer::FaceSetup* face = nullptr;
  double iz = 0.0;
};

/// The nearest of `faces` (indices into `setups`) that the ray through the sub-pixel point
/// (us, vs) meets within [near, far], given as inverse depths.
FaceHit nearest_face(const std::vector<Renderer::FaceSetup>& setups, std::span<const int> faces,
                     double us, double vs, double iz_near, double iz_far) {
  FaceHit best;
  for (const int c : faces) {
    const Renderer::FaceSetup& fs = setups[static_cast<std::size_t>(c)];
    const double iz = fs.iz0 + fs.izu * us + fs.izv * vs;
    if (!(iz > best.iz) || iz < iz_far || iz > iz_near) continue;
    if (fs.bounded) {
      const double z = 1.0 / iz;
      const double s = z * (fs.s0 + fs.su * us + fs.sv * vs) - fs.s_off;
      const double t = z * (fs.t0 + fs.tu * us + fs.tv * vs) - fs.t_off;
      if (s < -kEdgeMargin || s > fs.extent_s + kEdgeMargin || t < -kEdgeMargin ||
          t > fs.extent_t + kEdgeMargin) {
        continue;
      }
    }
    best = {&fs, iz};
  }
  return best;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// RenderOptions

void RenderOptions::validate() const {
  if (!(near_m > 0.0) || !(far_m > near_m)) {
    throw std::invalid_argument("RenderOptions: need 0 < near_m < far_m");
  }
  if (edge_supersampling < 1 || edge_supersampling > 8) {
    throw std::invalid_argument("RenderOptions: edge_supersampling must be in 1..8");
  }
  noise.validate();
}

std::string RenderOptions::describe() const {
  std::ostringstream os;
  os << "near " << near_m << " m, far " << far_m << " m, edge supersampling " << edge_supersampling
     << "x" << edge_supersampling << ", mipmapping " << (mipmapping ? "on" : "off")
     << ", noise: " << noise.describe();
  return os.str();
}

std::string RenderOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

RenderOptions RenderOptions::load_yaml(const std::filesystem::path& path) {
  RenderOptions o;
  io::option_fields::read_fields(io::load_yaml_map(path, "render"), path.string(), "render", o);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

// ---------------------------------------------------------------------------------------------
// Renderer

Renderer::Renderer(const PinholeCamera& camera, const RenderOptions& options, std::uint64_t seed)
    : camera_(camera),
      options_(options),
      noise_(options_.noise, seed),
      rig_free_noise_(options_.noise, seed + 1) {
  if (camera.has_distortion()) {
    throw std::invalid_argument(
        "Renderer: the camera has lens distortion; render camera.without_distortion()");
  }
  options_.validate();
  const int w = camera.width();
  const int h = camera.height();
  inv_depth_.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0);
  face_id_.assign(inv_depth_.size(), -1);
  radiance_.create(h, w, CV_32FC3);
  exact_depth_.create(h, w, CV_32F);
  cos_incidence_.create(h, w, CV_32F);
  cos_incidence_.setTo(1.0);  // only computed when the noise model needs it
}

void Renderer::add_rig_light(std::shared_ptr<const LightSource> light) {
  if (!light) throw std::invalid_argument("Renderer::add_rig_light: null light");
  rig_lights_.push_back(std::move(light));
}

RenderedFrame Renderer::render(const Scene& scene, const SE3& T_world_cam) {
  RenderedFrame frame;
  render(scene, T_world_cam, frame);
  return frame;
}

void Renderer::render(const Scene& scene, const SE3& T_world_cam, RenderedFrame& frame,
                      RenderedFrame* without_rig_lights) {
  setup_faces(scene, T_world_cam);
  rasterize();
  shade(scene, T_world_cam, frame, without_rig_lights);
}

void Renderer::setup_faces(const Scene& scene, const SE3& T_world_cam) {
  const double fx = camera_.fx(), fy = camera_.fy(), cx = camera_.cx(), cy = camera_.cy();
  const int w = camera_.width();
  const int h = camera_.height();
  const SE3 T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3d R_cw = T_cam_world.rotation_matrix();
  const auto& faces = scene.faces();
  setups_.resize(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const Face& f = faces[i];
    FaceSetup& fs = setups_[i];
    fs.face = &f;
    fs.visible = false;
    const Eigen::Vector3d o = T_cam_world * f.origin_world;
    const Eigen::Vector3d n = R_cw * f.normal;
    const Eigen::Vector3d a = R_cw * f.axis_s;
    const Eigen::Vector3d b = R_cw * f.axis_t;
    const double d = n.dot(o);
    // The camera lies in the plane (sees it edge-on), or behind a one-sided face.
    if (d == 0.0 || (f.one_sided && d > 0.0)) continue;
    fs.d_cam = d;
    fs.izu = n.x() / (fx * d);
    fs.izv = n.y() / (fy * d);
    fs.iz0 = (n.z() - n.x() * cx / fx - n.y() * cy / fy) / d;
    fs.su = a.x() / fx;
    fs.sv = a.y() / fy;
    fs.s0 = a.z() - a.x() * cx / fx - a.y() * cy / fy;
    fs.s_off = a.dot(o);
    fs.tu = b.x() / fx;
    fs.tv = b.y() / fy;
    fs.t0 = b.z() - b.x() * cx / fx - b.y() * cy / fy;
    fs.t_off = b.dot(o);
    fs.bounded = f.bounded();
    fs.extent_s = f.size_s_m;
    fs.extent_t = f.size_t_m;
    fs.n_world_facing = d < 0.0 ? f.normal : Eigen::Vector3d(-f.normal);
    const double texel = f.material.texture->texel_size_m();
    fs.inv_texel2 = 1.0 / (texel * texel);
    if (fs.bounded) {
      const std::array<Eigen::Vector3d, 4> corners{
          o, o + f.size_s_m * a, o + f.size_s_m * a + f.size_t_m * b, o + f.size_t_m * b};
      std::array<Eigen::Vector3d, 8> clipped;
      const int n_clipped = clip_near(corners, options_.near_m, clipped);
      if (n_clipped == 0) continue;
      double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;
      for (int k = 0; k < n_clipped; ++k) {
        const Eigen::Vector3d& p = clipped[static_cast<std::size_t>(k)];
        const double u = fx * p.x() / p.z() + cx;
        const double v = fy * p.y() / p.z() + cy;
        u_lo = std::min(u_lo, u);
        u_hi = std::max(u_hi, u);
        v_lo = std::min(v_lo, v);
        v_hi = std::max(v_hi, v);
      }
      // One pixel of slack: the per-pixel inside test decides exactly.
      fs.u_min = static_cast<int>(std::clamp(std::floor(u_lo) - 1.0, 0.0, w - 1.0));
      fs.u_max = static_cast<int>(std::clamp(std::ceil(u_hi) + 1.0, -1.0, w - 1.0));
      fs.v_min = static_cast<int>(std::clamp(std::floor(v_lo) - 1.0, 0.0, h - 1.0));
      fs.v_max = static_cast<int>(std::clamp(std::ceil(v_hi) + 1.0, -1.0, h - 1.0));
      if (u_hi < -1.0 || v_hi < -1.0 || u_lo > w || v_lo > h) continue;
    } else {
      fs.u_min = 0;
      fs.u_max = w - 1;
      fs.v_min = 0;
      fs.v_max = h - 1;
    }
    fs.visible = fs.u_min <= fs.u_max && fs.v_min <= fs.v_max;
  }
}

void Renderer::rasterize() {
  const int w = camera_.width();
  std::fill(inv_depth_.begin(), inv_depth_.end(), 0.0);
  std::fill(face_id_.begin(), face_id_.end(), -1);
  const double iz_near = 1.0 / options_.near_m;
  const double iz_far = 1.0 / options_.far_m;
  for (std::size_t i = 0; i < setups_.size(); ++i) {
    const FaceSetup& fs = setups_[i];
    if (!fs.visible) continue;
    const int id = static_cast<int>(i);
    const double s_hi = fs.extent_s + kEdgeMargin;
    const double t_hi = fs.extent_t + kEdgeMargin;
    for (int v = fs.v_min; v <= fs.v_max; ++v) {
      double* zrow = inv_depth_.data() + static_cast<std::size_t>(v) * static_cast<std::size_t>(w);
      int* idrow = face_id_.data() + static_cast<std::size_t>(v) * static_cast<std::size_t>(w);
      const double iz_row = fs.iz0 + fs.izv * v;
      const double s_row = fs.s0 + fs.sv * v;
      const double t_row = fs.t0 + fs.tv * v;
      for (int u = fs.u_min; u <= fs.u_max; ++u) {
        const double iz = iz_row + fs.izu * u;
        // Nearer than what is there (zrow starts at 0: nothing), within [near, far].
        if (!(iz > zrow[u]) || iz < iz_far || iz > iz_near) continue;
        if (fs.bounded) {
          const double z = 1.0 / iz;
          const double s = z * (s_row + fs.su * u) - fs.s_off;
          const double t = z * (t_row + fs.tu * u) - fs.t_off;
          if (s < -kEdgeMargin || s > s_hi || t < -kEdgeMargin || t > t_hi) continue;
        }
        zrow[u] = iz;
        idrow[u] = id;
      }
    }
  }
}

/// One frame's shading constants (camera, pose, lights, edge sampling) and the per-sample steps
/// that both shading passes share; defined in the class so that they inline into the loops.
struct Renderer::Shading {
  Shading(const Renderer& renderer, const Scene& scene, const SE3& T_world_cam,
          bool without_rig_lights)
      : rig_lights(renderer.rig_lights_),
        context{scene, T_world_cam},
        R_wc(T_world_cam.rotation_matrix()),
        t_wc(T_world_cam.translation()),
        cx(renderer.camera_.cx()),
        cy(renderer.camera_.cy()),
        inv_fx(1.0 / renderer.camera_.fx()),
        inv_fy(1.0 / renderer.camera_.fy()),
        ambient(scene.ambient()),
        has_lights(!scene.lights().empty() || !renderer.rig_lights_.empty()),
        mipmapping(renderer.options_.mipmapping),
        need_incidence(renderer.options_.noise.max_incidence_deg < 90.0),
        edge_k(renderer.options_.edge_supersampling),
        edge_lod_bias(-std::log2(static_cast<float>(edge_k))),
        iz_near(1.0 / renderer.options_.near_m),
        iz_far(1.0 / renderer.options_.far_m),
        rig_free(without_rig_lights) {}

  /// Albedo x texture of face `fs` seen through (u, v) at depth z (z = 1 / inverse depth).
  [[nodiscard]] ColorBgr surface_color(const FaceSetup& fs, double u, double v, double z,
                                       float lod_bias) const {
    const double sr = fs.s0 + fs.su * u + fs.sv * v;
    const double tr = fs.t0 + fs.tu * u + fs.tv * v;
    const double zs = z * sr;
    const double zt = z * tr;
    const Texture& tex = *fs.face->material.texture;
    ColorBgr color;
    if (mipmapping) {
      // Footprint of one pixel on the surface: derivatives of (s, t) = (z sr, z tr) with
      // z = 1 / iz, e.g. ds/du = z (su - z sr izu); isotropic (the longer axis), as in GL.
      const double dsdu = z * (fs.su - zs * fs.izu), dtdu = z * (fs.tu - zt * fs.izu);
      const double dsdv = z * (fs.sv - zs * fs.izv), dtdv = z * (fs.tv - zt * fs.izv);
      const auto ratio2 = static_cast<float>(
          std::max(dsdu * dsdu + dtdu * dtdu, dsdv * dsdv + dtdv * dtdv) * fs.inv_texel2);
      // Magnified (footprint below a texel) and no bias: plain bilinear, no log needed.
      const float lod =
          (ratio2 <= 1.0F && lod_bias == 0.0F) ? 0.0F : 0.5F * fast_log2(ratio2) + lod_bias;
      color = tex.sample_lod(zs - fs.s_off, zt - fs.t_off, lod);
    } else {
      color = tex.sample(zs - fs.s_off, zt - fs.t_off);
    }
    return color.mul(fs.face->material.albedo);
  }

  /// The world point of face `fs` seen through (u, v) at depth z, as the lights take it.
  [[nodiscard]] SurfacePoint surface_point(const FaceSetup& fs, double u, double v,
                                           double z) const {
    const Eigen::Vector3d p_cam(z * (u - cx) * inv_fx, z * (v - cy) * inv_fy, z);
    return SurfacePoint{R_wc * p_cam + t_wc, fs.n_world_facing, fs.face->primitive};
  }

  /// Adds the scene's lights' irradiance at `points` to `irradiance`.
  void light_scene(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance) const {
    for (const auto& l : context.scene.lights()) l->accumulate(points, irradiance, context);
  }
  /// Adds the rig lights' (after the scene's: the sums are those of one list of lights).
  void light_rig(std::span<const SurfacePoint> points, std::span<ColorBgr> irradiance) const {
    for (const auto& l : rig_lights) l->accumulate(points, irradiance, context);
  }

  const std::vector<std::shared_ptr<const LightSource>>& rig_lights;
  ShadingContext context;
  Eigen::Matrix3d R_wc;
  Eigen::Vector3d t_wc;
  double cx, cy, inv_fx, inv_fy;
  float ambient;
  bool has_lights;
  bool mipmapping;
  // The angle of incidence only matters to the grazing-angle dropout of the noise model.
  bool need_incidence;
  int edge_k;           // k x k samples per edge pixel; 1: no supersampling
  float edge_lod_bias;  // the samples' footprint is 1/k of a pixel's
  double iz_near, iz_far;
  bool rig_free;  // also shade the view without the rig lights
};

void Renderer::shade(const Scene& scene, const SE3& T_world_cam, RenderedFrame& frame,
                     RenderedFrame* without_rig_lights) {
  const Shading shading(*this, scene, T_world_cam, without_rig_lights != nullptr);
  if (shading.rig_free) rig_free_radiance_.create(camera_.height(), camera_.width(), CV_32FC3);
  // One row of points, or the k x k (<= 64) samples of an edge pixel.
  const int w = camera_.width();
  const auto batch = static_cast<std::size_t>(std::max(w, 64));
  row_points_.resize(batch);
  row_irradiance_.resize(batch);
  row_columns_.resize(static_cast<std::size_t>(w));
  shade_pixel_centres(shading);
  shade_edge_pixels(shading);
  write_frame(radiance_, noise_, frame);
  if (shading.rig_free) write_frame(rig_free_radiance_, rig_free_noise_, *without_rig_lights);
}

// Every pixel at its centre ray; the lights are evaluated once per row, in a batch.
void Renderer::shade_pixel_centres(const Shading& shading) {
  const int w = camera_.width();
  const int h = camera_.height();
  for (int v = 0; v < h; ++v) {
    const std::size_t row = static_cast<std::size_t>(v) * static_cast<std::size_t>(w);
    auto* rad = radiance_.ptr<cv::Vec3f>(v);
    auto* depth = exact_depth_.ptr<float>(v);
    auto* cosi = cos_incidence_.ptr<float>(v);
    auto* free = shading.rig_free ? rig_free_radiance_.ptr<cv::Vec3f>(v) : nullptr;
    const double y = (v - shading.cy) * shading.inv_fy;
    std::size_t n_lit = 0;
    for (int u = 0; u < w; ++u) {
      const int id = face_id_[row + static_cast<std::size_t>(u)];
      if (id < 0) {
        rad[u] = ColorBgr(0.0F, 0.0F, 0.0F);
        if (free != nullptr) free[u] = rad[u];
        depth[u] = kNoDepth;
        cosi[u] = 0.0F;
        continue;
      }
      const FaceSetup& fs = setups_[static_cast<std::size_t>(id)];
      const double iz = inv_depth_[row + static_cast<std::size_t>(u)];
      const double z = 1.0 / iz;
      depth[u] = static_cast<float>(z);
      if (shading.need_incidence) {
        // |cos| between the ray r = (x, y, 1) and the normal: n.r = iz * d_cam.
        const double x = (u - shading.cx) * shading.inv_fx;
        cosi[u] = static_cast<float>(std::abs(iz * fs.d_cam) / std::sqrt(x * x + y * y + 1.0));
      }
      rad[u] = shading.surface_color(fs, u, v, z, 0.0F);
      if (shading.has_lights) {
        row_points_[n_lit] = shading.surface_point(fs, u, v, z);
        row_irradiance_[n_lit] = ColorBgr(shading.ambient, shading.ambient, shading.ambient);
        row_columns_[n_lit] = u;
        ++n_lit;
      } else {
        rad[u] *= shading.ambient;
        if (free != nullptr) free[u] = rad[u];
      }
    }
    if (n_lit > 0) {
      const std::span<const SurfacePoint> points{row_points_.data(), n_lit};
      const std::span<ColorBgr> irradiance{row_irradiance_.data(), n_lit};
      shading.light_scene(points, irradiance);
      if (free != nullptr) {
        for (std::size_t i = 0; i < n_lit; ++i) {
          const int u = row_columns_[i];
          free[u] = rad[u].mul(row_irradiance_[i]);
        }
      }
      shading.light_rig(points, irradiance);
      for (std::size_t i = 0; i < n_lit; ++i) {
        cv::Vec3f& r = rad[row_columns_[i]];
        r = r.mul(row_irradiance_[i]);
      }
    }
  }
}

// Pixels on a boundary (a 4-neighbour shows another face) get k x k colour samples, each
// taking the nearest of the faces seen in the 3x3 neighbourhood.
void Renderer::shade_edge_pixels(const Shading& shading) {
  edge_pixels_ = 0;
  if (shading.edge_k <= 1) return;
  const int w = camera_.width();
  const int h = camera_.height();
  std::array<int, 9> faces{};
  std::array<ColorBgr, 64> sample_color;  // k <= 8
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (!on_face_boundary(face_id_, u, v, w, h)) continue;
      ++edge_pixels_;
      const std::size_t n_faces = faces_around(face_id_, u, v, w, h, faces);
      ColorBgr rig_free;
      radiance_.at<cv::Vec3f>(v, u) =
          supersample_pixel(shading, u, v, {faces.data(), n_faces}, sample_color, rig_free);
      if (shading.rig_free) rig_free_radiance_.at<cv::Vec3f>(v, u) = rig_free;
    }
  }
}

ColorBgr Renderer::supersample_pixel(const Shading& shading, int u, int v,
                                     std::span<const int> faces, std::span<ColorBgr> sample_color,
                                     ColorBgr& rig_free) {
  const int k = shading.edge_k;
  std::size_t n_samples = 0;
  for (int j = 0; j < k; ++j) {
    const double vs = v + (j + 0.5) / k - 0.5;
    for (int i = 0; i < k; ++i) {
      const double us = u + (i + 0.5) / k - 0.5;
      const FaceHit hit = nearest_face(setups_, faces, us, vs, shading.iz_near, shading.iz_far);
      if (hit.face == nullptr) continue;  // background: black
      const double z = 1.0 / hit.iz;
      sample_color[n_samples] = shading.surface_color(*hit.face, us, vs, z, shading.edge_lod_bias);
      if (shading.has_lights) {
        row_points_[n_samples] = shading.surface_point(*hit.face, us, vs, z);
        row_irradiance_[n_samples] = ColorBgr(shading.ambient, shading.ambient, shading.ambient);
      }
      ++n_samples;
    }
  }
  // The lights see the pixel's samples in one batch.
  const float scale = 1.0F / static_cast<float>(k * k);
  auto average = [&] {
    ColorBgr sum(0.0F, 0.0F, 0.0F);
    for (std::size_t i = 0; i < n_samples; ++i) {
      sum += shading.has_lights ? sample_color[i].mul(row_irradiance_[i])
                                : sample_color[i] * shading.ambient;
    }
    return sum * scale;
  };
  if (shading.has_lights && n_samples > 0) {
    const std::span<const SurfacePoint> points{row_points_.data(), n_samples};
    const std::span<ColorBgr> irradiance{row_irradiance_.data(), n_samples};
    shading.light_scene(points, irradiance);
    if (shading.rig_free) rig_free = average();
    shading.light_rig(points, irradiance);
  } else if (shading.rig_free) {
    rig_free = average();
  }
  return average();
}

// Sensor noise, then the output images.
void Renderer::write_frame(cv::Mat& radiance, SensorNoise& noise, RenderedFrame& frame) {
  const int w = camera_.width();
  const int h = camera_.height();
  frame.depth_m.create(h, w, CV_32F);
  exact_depth_.copyTo(frame.depth_m);
  const SensorNoiseOptions& no = noise.options();
  if (no.depth_noise_enabled()) noise.apply_depth(frame.depth_m, cos_incidence_);
  if (no.intensity_sigma > 0.0) noise.apply_intensity(radiance);

  frame.color_bgr.create(h, w, CV_8UC3);
  frame.gray.create(h, w, CV_32F);
  frame.primitive_id.create(h, w, CV_32S);
  for (int v = 0; v < h; ++v) {
    const auto* rad = radiance.ptr<cv::Vec3f>(v);
    auto* bgr = frame.color_bgr.ptr<cv::Vec3b>(v);
    auto* gray = frame.gray.ptr<float>(v);
    auto* prim = frame.primitive_id.ptr<int>(v);
    const int* ids = face_id_.data() + static_cast<std::size_t>(v) * static_cast<std::size_t>(w);
    for (int u = 0; u < w; ++u) {
      const float b = std::clamp(rad[u][0], 0.0F, 1.0F) * 255.0F;
      const float g = std::clamp(rad[u][1], 0.0F, 1.0F) * 255.0F;
      const float r = std::clamp(rad[u][2], 0.0F, 1.0F) * 255.0F;
      bgr[u] = cv::Vec3b(cv::saturate_cast<std::uint8_t>(b), cv::saturate_cast<std::uint8_t>(g),
                         cv::saturate_cast<std::uint8_t>(r));
      gray[u] = (b + g + r) * (1.0F / 3.0F);
      prim[u] = ids[u] < 0 ? -1 : setups_[static_cast<std::size_t>(ids[u])].face->primitive;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// StereoRenderer

StereoRenderer::StereoRenderer(const RectifiedStereo& rig, const RenderOptions& options,
                               std::uint64_t seed)
    : rig_((rig.validate(), rig)),
      left_(rig.left(), options, derive_seed(seed, 0)),
      right_(rig.left(), options, derive_seed(seed, 1)) {}

SE3 StereoRenderer::T_left_right() const {
  return SE3(SO3(), Eigen::Vector3d(rig_.baseline_m, 0.0, 0.0));
}

void StereoRenderer::add_rig_light(const std::shared_ptr<const LightSource>& light) {
  left_.add_rig_light(light);
  right_.add_rig_light(light);
}

void StereoRenderer::render(const Scene& scene, const SE3& T_world_left, StereoFrame& frame,
                            RenderedFrame* left_without_rig_lights) {
  // The views render concurrently: separate renderers (buffers, noise generators), the scene
  // and its lights const, so the frame is the same as rendering one after the other.
  const SE3 T_world_right = T_world_left * T_left_right();
  std::future<void> right = std::async(std::launch::async, [this, &scene, &T_world_right, &frame] {
    right_.render(scene, T_world_right, frame.right);
  });
  left_.render(scene, T_world_left, frame.left, left_without_rig_lights);
  right.get();
  const cv::Mat& z = left_.exact_depth_m();
  frame.disparity_px.create(z.size(), CV_32F);
  const double bf = rig_.baseline_m * rig_.f;
  for (int v = 0; v < z.rows; ++v) {
    const auto* zr = z.ptr<float>(v);
    auto* dr = frame.disparity_px.ptr<float>(v);
    for (int u = 0; u < z.cols; ++u) {
      dr[u] = zr[u] > 0.0F ? static_cast<float>(bf / static_cast<double>(zr[u])) : kNoDepth;
    }
  }
}

}  // namespace kestrel::sim
