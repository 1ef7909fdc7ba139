// The renderer against known answers: back-projected depth lies on the analytic surface of the
// primitive hit, exact plane depths, texture colours at projected points, stereo disparity
// B f / Z, edge supersampling and mip-mapping, the light hook, determinism.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {
namespace {

/// The ROS default camera at a quarter of its size (160 x 120): small, fast in Debug builds.
PinholeCamera small_camera() { return PinholeCamera({525.0 / 4, 525.0 / 4, 79.5, 59.5, 160, 120}); }

/// Named scenes are built once per test program (textures take a moment in Debug builds).
const Scene& named_scene(const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<Scene>> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[name];
  if (!slot) slot = std::make_unique<Scene>(make_scene(name));
  return *slot;
}

Material textured(std::shared_ptr<const Texture> tex, ColorBgr albedo = {1.0F, 1.0F, 1.0F}) {
  return {std::move(tex), albedo};
}

std::shared_ptr<const Texture> noise_texture(double texel_m, std::uint64_t seed = 4) {
  ValueNoiseOptions o;
  o.size_px = 128;
  o.texel_size_m = texel_m;
  o.base_cells = 8;
  o.octaves = 3;
  o.dark = {0.1F, 0.2F, 0.3F};
  o.bright = {0.9F, 0.8F, 0.7F};
  return std::make_shared<const Texture>(make_value_noise_texture(o, seed));
}

/// Distance of p_world from the surface of a primitive, from its analytic description alone.
double distance_to_surface(const Primitive& primitive, const Eigen::Vector3d& p_world) {
  if (const auto* r = std::get_if<PlanarRect>(&primitive)) {
    const Eigen::Vector3d p = r->T_world_rect.inverse() * p_world;
    const Eigen::Vector3d on(std::clamp(p.x(), 0.0, r->width_m),
                             std::clamp(p.y(), 0.0, r->height_m), 0.0);
    return (p - on).norm();
  }
  if (const auto* plane = std::get_if<InfinitePlane>(&primitive)) {
    return std::abs((plane->T_world_plane.inverse() * p_world).z());
  }
  const auto& box = std::get<OrientedBox>(primitive);
  const Eigen::Vector3d p = (box.T_world_box.inverse() * p_world).cwiseAbs();
  const Eigen::Vector3d outside = (p - box.half_extents_m).cwiseMax(0.0);
  if (outside.norm() > 0.0) return outside.norm();
  return (box.half_extents_m - p).minCoeff();  // inside: distance to the nearest face
}

/// Camera poses for a scene: its start, a hand-held pose, and a tilted one.
std::vector<SE3> poses_for(const Scene& scene) {
  std::vector<SE3> poses;
  const SE3 mount = forward_camera_mount();
  const SmoothTrajectory handheld = make_trajectory("handheld", scene.T_world_start(), 3);
  poses.push_back(scene.T_world_start() * mount);
  poses.push_back(handheld.T_world_body(2.3) * mount);
  // Looking down and sideways, so that floors and box tops are seen at grazing angles too.
  poses.push_back(scene.T_world_start() * SE3(SO3::exp({0.0, 0.6, -0.8}), {0.2, 0.0, 0.0}) * mount);
  return poses;
}

TEST(Renderer, BackProjectedDepthLiesOnTheSurfaceOfThePrimitiveHit) {
  const PinholeCamera camera = small_camera();
  Renderer renderer(camera);
  RenderedFrame frame;
  for (const auto& entry : scene_catalogue()) {
    const Scene& scene = named_scene(std::string(entry.name));
    for (const SE3& T_world_cam : poses_for(scene)) {
      renderer.render(scene, T_world_cam, frame);
      int checked = 0;
      double worst = 0.0;
      // Every other pixel of every other row (4800 per view; Debug builds are slow).
      for (int v = 0; v < camera.height(); v += 2) {
        for (int u = v % 4 / 2; u < camera.width(); u += 2) {
          const int id = frame.primitive_id.at<int>(v, u);
          const float z = frame.depth_m.at<float>(v, u);
          if (id < 0) {
            EXPECT_EQ(z, kNoDepth);
            continue;
          }
          ASSERT_GT(z, 0.0F);
          const Eigen::Vector3d p_world =
              T_world_cam * camera.unproject({u, v}, static_cast<double>(z));
          const double d =
              distance_to_surface(scene.primitives()[static_cast<std::size_t>(id)], p_world);
          worst = std::max(worst, d);
          ++checked;
        }
      }
      EXPECT_LT(worst, 1e-4) << entry.name;
      // Rooms and corridors are closed: every ray hits something.
      if (entry.name == "office" || entry.name == "corridor") {
        EXPECT_EQ(checked, camera.width() * camera.height() / 4) << entry.name;
      } else {
        EXPECT_GT(checked, camera.width() * camera.height() / 12) << entry.name;
      }
    }
  }
}

TEST(Renderer, DepthIsThatOfTheNearestSurfaceAlongThePixelRay) {
  // The renderer's z-buffer against the scene's slow ray query, on a sample of pixels.
  const PinholeCamera camera = small_camera();
  Renderer renderer(camera);
  for (const char* name : {"office", "checker"}) {
    const Scene& scene = named_scene(name);
    const SE3 T_world_cam = poses_for(scene)[1];
    const RenderedFrame frame = renderer.render(scene, T_world_cam);
    for (int v = 1; v < camera.height(); v += 7) {
      for (int u = 2; u < camera.width(); u += 9) {
        const Eigen::Vector3d ray = camera.unproject({u, v}, 1.0);
        const auto hit = scene.intersect(T_world_cam.translation(), T_world_cam.so3() * ray,
                                         renderer.options().near_m);
        if (!hit) {  // open scenes: the sky
          EXPECT_EQ(frame.primitive_id.at<int>(v, u), -1) << name << " " << u << "," << v;
          EXPECT_EQ(frame.depth_m.at<float>(v, u), kNoDepth);
          continue;
        }
        const double z_expected = hit->distance / ray.norm();
        EXPECT_NEAR(frame.depth_m.at<float>(v, u), z_expected, 1e-5 * z_expected)
            << name << " " << u << "," << v;
        EXPECT_EQ(frame.primitive_id.at<int>(v, u), hit->primitive) << name;
      }
    }
  }
}

TEST(Renderer, FrontoParallelAndTiltedPlaneDepthsAreExact) {
  const PinholeCamera camera = small_camera();
  Renderer renderer(camera);
  Scene scene;
  scene.add(PlanarRect::from_corner({-50, -50, 2.5}, {1, 0, 0}, {0, 1, 0}, 100, 100,
                                    textured(noise_texture(0.01))));
  RenderedFrame frame = renderer.render(scene, SE3());
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      ASSERT_EQ(frame.depth_m.at<float>(v, u), 2.5F) << u << "," << v;
    }
  }
  // A plane n . p = d seen from a rotated camera: Z = d / (n . R r) at every pixel.
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  const double d = 3.0;
  Scene tilted;
  tilted.add(InfinitePlane{
      SE3(SO3::from_matrix(
              Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), n).toRotationMatrix()),
          d * n),
      textured(noise_texture(0.01))});
  const SE3 T_world_cam(SO3::exp({0.1, 0.05, -0.2}), {0.3, -0.1, 0.2});
  frame = renderer.render(tilted, T_world_cam);
  const double d_cam = d - n.dot(T_world_cam.translation());
  const Eigen::Vector3d n_cam = T_world_cam.so3().inverse() * n;
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      const Eigen::Vector3d r((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy(),
                              1.0);
      const double z = d_cam / n_cam.dot(r);
      ASSERT_NEAR(frame.depth_m.at<float>(v, u), z, 2e-7 * z) << u << "," << v;
    }
  }
}

TEST(Renderer, PixelShowsTheTextureColourOfItsSurfacePoint) {
  // Close to a plane (each pixel smaller than a texel: no prefiltering), ambient light only:
  // the colour of every pixel is the texture at the surface point of its centre ray.
  const PinholeCamera camera({400.0, 400.0, 79.5, 59.5, 160, 120});
  RenderOptions options;
  options.edge_supersampling = 1;
  Renderer renderer(camera, options);
  const auto tex = noise_texture(0.008);
  const ColorBgr albedo(0.9F, 1.0F, 0.8F);
  Scene scene;
  scene.set_ambient(1.0F);
  const SE3 T_world_rect(SO3::exp({0.2, -0.1, 0.3}), {-0.7, -0.6, 1.0});
  scene.add(PlanarRect{T_world_rect, 2.0, 2.0, textured(tex, albedo)});
  const SE3 T_world_cam(SO3::exp({0.05, 0.1, 0.0}), {0.1, 0.0, 0.0});
  const RenderedFrame frame = renderer.render(scene, T_world_cam);
  const SE3 T_rect_cam = T_world_rect.inverse() * T_world_cam;
  auto expected_at = [&](const Eigen::Vector3d& p_rect) {
    const ColorBgr c = tex->sample(p_rect.x(), p_rect.y()).mul(albedo);
    return cv::Vec3d(255.0 * static_cast<double>(c[0]), 255.0 * static_cast<double>(c[1]),
                     255.0 * static_cast<double>(c[2]));
  };
  int checked = 0;
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      const float z = frame.depth_m.at<float>(v, u);
      if (z <= 0.0F) continue;
      const Eigen::Vector3d p_rect = T_rect_cam * camera.unproject({u, v}, static_cast<double>(z));
      const cv::Vec3d want = expected_at(p_rect);
      const cv::Vec3b got = frame.color_bgr.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[c], want[c], 0.51) << u << "," << v;
      EXPECT_NEAR(frame.gray.at<float>(v, u), (want[0] + want[1] + want[2]) / 3.0, 1e-3);
      ++checked;
    }
  }
  EXPECT_GT(checked, 10000);
  // The other way round: points of the surface projected into the image (between pixel
  // centres) show their texture colour, to the accuracy of bilinear interpolation.
  cv::Mat gray = frame.gray;
  double max_err = 0.0;
  for (double s = 0.61; s < 1.4; s += 0.0537) {
    for (double t = 0.55; t < 1.3; t += 0.0611) {
      const Eigen::Vector3d p_cam = T_rect_cam.inverse() * Eigen::Vector3d(s, t, 0.0);
      const Eigen::Vector2d uv = camera.project(p_cam);
      if (uv.x() < 1 || uv.y() < 1 || uv.x() > camera.width() - 2 || uv.y() > camera.height() - 2) {
        continue;
      }
      cv::Mat patch;
      cv::getRectSubPix(gray, {1, 1},
                        cv::Point2f(static_cast<float>(uv.x()), static_cast<float>(uv.y())), patch);
      const cv::Vec3d want = expected_at({s, t, 0.0});
      max_err = std::max(max_err, std::abs(static_cast<double>(patch.at<float>(0, 0)) -
                                           (want[0] + want[1] + want[2]) / 3.0));
    }
  }
  EXPECT_LT(max_err, 1.5);  // grey levels
}

TEST(Renderer, PointLightShadesLambertian) {
  const PinholeCamera camera = small_camera();
  RenderOptions options;
  options.edge_supersampling = 1;
  Renderer renderer(camera, options);
  Scene scene;
  scene.set_ambient(0.3F);
  const ColorBgr white(1.0F, 1.0F, 1.0F);
  scene.add(PlanarRect::from_corner(
      {-5, -5, 2.0}, {1, 0, 0}, {0, 1, 0}, 10, 10,
      textured(std::make_shared<const Texture>(Texture::constant({0.5F, 0.5F, 0.5F})))));
  const Eigen::Vector3d light(0.4, -0.2, 0.5);
  scene.add_light(std::make_shared<PointLight>(light, white * 0.8F, 1.5));
  const RenderedFrame frame = renderer.render(scene, SE3());
  for (int v = 0; v < camera.height(); v += 5) {
    for (int u = 0; u < camera.width(); u += 5) {
      const Eigen::Vector3d p = camera.unproject({u, v}, frame.depth_m.at<float>(v, u));
      const Eigen::Vector3d l = light - p;
      // The camera sees the plane's back (normal -z faces it).
      const double cos_t = std::max(0.0, -l.z() / l.norm());
      const double e = 0.8 * cos_t / (1.0 + l.squaredNorm() / (1.5 * 1.5));
      EXPECT_NEAR(frame.gray.at<float>(v, u), 255.0 * 0.5 * (0.3 + e), 0.01) << u << "," << v;
    }
  }
}

/// A light on the rig: lights every point by `level` if its context carries the expected
/// camera pose, else by nothing (so the test sees whether the pose was passed).
class PoseCheckingLight final : public LightSource {
 public:
  PoseCheckingLight(const SE3& expected, float level) : expected_(expected), level_(level) {}
  [[nodiscard]] ColorBgr illuminate(const SurfacePoint& /*point*/,
                                    const ShadingContext& context) const override {
    const bool ok = (context.T_world_cam.translation() - expected_.translation()).norm() < 1e-12;
    return ok ? ColorBgr(level_, level_, level_) : ColorBgr(0.0F, 0.0F, 0.0F);
  }
  [[nodiscard]] std::string describe() const override { return "test light"; }

 private:
  SE3 expected_;
  float level_;
};

TEST(Renderer, RigLightsGetTheCameraPose) {
  const PinholeCamera camera = small_camera();
  const Scene& scene = named_scene("checker");
  const SE3 T_world_cam = scene.T_world_start() * forward_camera_mount();
  Renderer plain(camera);
  Renderer lit(camera);
  lit.add_rig_light(std::make_shared<PoseCheckingLight>(T_world_cam, 0.25F));
  const RenderedFrame a = plain.render(scene, T_world_cam);
  const RenderedFrame b = lit.render(scene, T_world_cam);
  // Brighter by the extra light wherever nothing saturates: colour * (gain + 0.25).
  int brighter = 0, total = 0;
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      if (a.primitive_id.at<int>(v, u) < 0) continue;
      ++total;
      if (b.gray.at<float>(v, u) > a.gray.at<float>(v, u) + 1.0F) ++brighter;
    }
  }
  EXPECT_GT(brighter, total * 9 / 10);
}

TEST(Renderer, StereoDisparityIsBaselineTimesFocalOverDepth) {
  RectifiedStereo rig{131.25, 79.5, 59.5, 0.12, 160, 120};
  RenderOptions options;
  options.edge_supersampling = 1;
  StereoRenderer renderer(rig, options);
  const Scene& scene = named_scene("checker");
  const SE3 T_world_left = poses_for(scene)[1];
  StereoFrame frame;
  renderer.render(scene, T_world_left, frame);
  const PinholeCamera camera = rig.left();
  const SE3 T_world_right = T_world_left * renderer.T_left_right();
  int covisible = 0;
  double colour_err = 0.0;
  for (int v = 0; v < rig.height; ++v) {
    for (int u = 0; u < rig.width; ++u) {
      const float z = frame.left.depth_m.at<float>(v, u);
      const float d = frame.disparity_px.at<float>(v, u);
      if (z <= 0.0F) {
        EXPECT_EQ(d, kNoDepth);
        continue;
      }
      ASSERT_NEAR(d, rig.baseline_m * rig.f / static_cast<double>(z),
                  1e-5 * static_cast<double>(d));
      // The left point seen from the right camera: same row, d pixels to the left, same Z
      // (a pure x translation), where the right view sees the same surface.
      const Eigen::Vector3d p_world = T_world_left * camera.unproject({u, v}, z);
      const Eigen::Vector2d uv_r = camera.project(T_world_right.inverse() * p_world);
      ASSERT_NEAR(uv_r.x(), u - d, 1e-3);
      ASSERT_NEAR(uv_r.y(), v, 1e-6);
      const int ur = static_cast<int>(std::lround(uv_r.x()));
      if (ur < 1 || ur >= rig.width - 1) continue;
      const float zr = frame.right.depth_m.at<float>(v, ur);
      if (std::abs(zr - z) > 0.01F * z) continue;  // occluded in the right view
      ++covisible;
      cv::Mat patch;
      cv::getRectSubPix(frame.right.gray, {1, 1},
                        cv::Point2f(static_cast<float>(uv_r.x()), static_cast<float>(v)), patch);
      colour_err +=
          static_cast<double>(std::abs(patch.at<float>(0, 0) - frame.left.gray.at<float>(v, u)));
    }
  }
  ASSERT_GT(covisible, 5000);
  // Brightness constancy between the views (texture is view-independent); the residual is
  // the bilinear interpolation across checker edges.
  EXPECT_LT(colour_err / covisible, 3.0);
}

TEST(Renderer, EdgeSupersamplingSmoothsColourButKeepsDepth) {
  const PinholeCamera camera = small_camera();
  RenderOptions sharp;
  sharp.edge_supersampling = 1;
  RenderOptions smooth;
  smooth.edge_supersampling = 3;
  Renderer a(camera, sharp), b(camera, smooth);
  const Scene& scene = named_scene("wall");
  const SE3 T_world_cam = scene.T_world_start() * forward_camera_mount();
  const RenderedFrame fa = a.render(scene, T_world_cam);
  const RenderedFrame fb = b.render(scene, T_world_cam);
  EXPECT_EQ(cv::norm(fa.depth_m, fb.depth_m, cv::NORM_INF), 0.0);
  EXPECT_GT(b.edge_pixels(), 50U);
  EXPECT_EQ(a.edge_pixels(), 0U);
  cv::Mat diff = cv::abs(fa.gray - fb.gray);
  // Colours change only on the supersampled (edge) pixels.
  EXPECT_LE(static_cast<std::size_t>(cv::countNonZero(diff > 1e-3)), b.edge_pixels());
  EXPECT_GT(cv::sum(diff)[0], 50.0);
}

TEST(Renderer, MipMappingRemovesAliasingOnDistantTextures) {
  // A fine checkerboard 40 m away: many squares per pixel. Prefiltered, it is a uniform grey;
  // point-sampled, it is salt and pepper.
  const PinholeCamera camera = small_camera();
  Scene scene;
  scene.add(
      PlanarRect::from_corner({-100, -100, 40.0}, {1, 0, 0}, {0, 1, 0}, 200, 200,
                              textured(std::make_shared<const Texture>(make_checkerboard_texture(
                                  0.05, {0.0F, 0.0F, 0.0F}, {1.0F, 1.0F, 1.0F})))));
  RenderOptions with, without;
  without.mipmapping = false;
  Renderer a(camera, with), b(camera, without);
  cv::Scalar mean_a, sd_a, mean_b, sd_b;
  cv::meanStdDev(a.render(scene, SE3()).gray, mean_a, sd_a);
  cv::meanStdDev(b.render(scene, SE3()).gray, mean_b, sd_b);
  EXPECT_NEAR(mean_a[0], 127.5, 2.0);
  EXPECT_LT(sd_a[0], 2.0);
  EXPECT_GT(sd_b[0], 30.0);
}

TEST(Renderer, SameSeedSameFramesOtherSeedOtherNoise) {
  const PinholeCamera camera = small_camera();
  RenderOptions options;
  options.noise = SensorNoiseOptions::kinect();
  const Scene& scene = named_scene("office");
  const SE3 T_world_cam = scene.T_world_start() * forward_camera_mount();
  Renderer a(camera, options, 42), b(camera, options, 42), c(camera, options, 43);
  RenderedFrame fa, fb, fc;
  for (int i = 0; i < 2; ++i) {  // the second frames too: the generators advance alike
    a.render(scene, T_world_cam, fa);
    b.render(scene, T_world_cam, fb);
    c.render(scene, T_world_cam, fc);
    EXPECT_EQ(cv::norm(fa.color_bgr, fb.color_bgr, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(fa.depth_m, fb.depth_m, cv::NORM_INF), 0.0);
    EXPECT_GT(cv::norm(fa.color_bgr, fc.color_bgr, cv::NORM_L1), 1000.0);
    EXPECT_GT(cv::norm(fa.depth_m, fc.depth_m, cv::NORM_L1), 1.0);
  }
  // The exact depth is kept aside from the noisy one.
  EXPECT_GT(cv::norm(fa.depth_m, a.exact_depth_m(), cv::NORM_L1), 1.0);
  Renderer clean(camera);
  EXPECT_EQ(cv::norm(clean.render(scene, T_world_cam).depth_m, a.exact_depth_m(), cv::NORM_INF),
            0.0);
}

TEST(Renderer, RejectsDistortedCamerasAndBadOptions) {
  const PinholeCamera distorted({500, 500, 320, 240, 640, 480}, {0.1, 0.0, 0.0, 0.0, 0.0});
  EXPECT_THROW(Renderer r(distorted), std::invalid_argument);
  RenderOptions bad;
  bad.near_m = 0.0;
  EXPECT_THROW(Renderer r(small_camera(), bad), std::invalid_argument);
  bad = {};
  bad.edge_supersampling = 0;
  EXPECT_THROW(Renderer r(small_camera(), bad), std::invalid_argument);
  EXPECT_THROW(StereoRenderer r(RectifiedStereo{}), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::sim
