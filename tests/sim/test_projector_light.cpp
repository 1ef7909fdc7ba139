// The simulated projector: the pattern lands where the geometry says, shadows, 1/d^2
// fall-off, determinism per seed.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sim/projector_light.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {
namespace {

Material white() {
  return Material{std::make_shared<const Texture>(Texture::constant(ColorBgr(1.0F, 1.0F, 1.0F))),
                  ColorBgr(1.0F, 1.0F, 1.0F)};
}

/// A large white plane z = z_m in the world (= left camera) frame.
PlanarRect plane_at(double z_m, double half_size_m = 10.0) {
  return PlanarRect::from_corner(Eigen::Vector3d(-half_size_m, -half_size_m, z_m),
                                 Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                 2.0 * half_size_m, 2.0 * half_size_m, white());
}

ProjectorOptions small_projector() {
  ProjectorOptions o;
  o.width = 320;
  o.height = 180;
  o.blur_sigma_px = 0.0;
  return o;
}

RectifiedStereo small_rig() { return RectifiedStereo::centred(160, 120, 100.0, 0.1); }

RenderOptions exact_render() {
  RenderOptions r;
  r.edge_supersampling = 1;
  return r;
}

TEST(Projector, PatternLandsWherePredicted) {
  const ProjectorOptions o = small_projector();
  const PinholeCamera proj = o.camera();
  // A bright 5x5 dot centred on projector pixel (200, 60), everything else black.
  cv::Mat pattern(o.height, o.width, CV_8UC3, cv::Scalar::all(0));
  const int pu = 200, pv = 60;
  pattern(cv::Rect(pu - 2, pv - 2, 5, 5)).setTo(cv::Scalar::all(255));
  const double z_plane = 2.0;
  Scene scene("plane");
  scene.add(plane_at(z_plane));
  const RectifiedStereo rig = small_rig();
  const StereoFrame frame =
      render_active_stereo(scene, rig, SE3(), pattern, ProjectorMode::kDarkRoom, o, exact_render());
  // The projector ray of (pu, pv) hits z = z_plane at p_left; the cameras see it at
  // (f x / z + cu, f y / z + cv) and, in the right view, B f / z further left.
  const Eigen::Vector3d ray((pu - proj.cx()) / proj.fx(), (pv - proj.cy()) / proj.fy(), 1.0);
  const Eigen::Vector3d c = o.T_left_projector.translation();
  const Eigen::Vector3d r_left = o.T_left_projector.rotation_matrix() * ray;
  const Eigen::Vector3d p = c + r_left * ((z_plane - c.z()) / r_left.z());
  const double u_pred = rig.f * p.x() / p.z() + rig.cu;
  const double v_pred = rig.f * p.y() / p.z() + rig.cv;
  for (int view = 0; view < 2; ++view) {
    const cv::Mat& gray = view == 0 ? frame.left.gray : frame.right.gray;
    const cv::Moments m = cv::moments(gray, false);
    ASSERT_GT(m.m00, 0.0) << "view " << view << " got no pattern";
    const double u_expected = view == 0 ? u_pred : u_pred - rig.baseline_m * rig.f / z_plane;
    EXPECT_NEAR(m.m10 / m.m00, u_expected, 0.3) << "view " << view;
    EXPECT_NEAR(m.m01 / m.m00, v_pred, 0.3) << "view " << view;
  }
  // The true disparity is B f / Z everywhere on the plane.
  EXPECT_NEAR(frame.disparity_px.at<float>(60, 80), rig.baseline_m * rig.f / z_plane, 1e-4);
}

TEST(Projector, OccludedPointsGetNoPattern) {
  ProjectorOptions o = small_projector();
  const cv::Mat pattern(o.height, o.width, CV_8UC3, cv::Scalar::all(255));
  Scene scene("shadow");
  scene.add(plane_at(2.0));
  // A 20 cm occluder at z = 1 straight ahead of the projector (at the world origin).
  scene.add(PlanarRect::from_corner(Eigen::Vector3d(-0.1, -0.1, 1.0), Eigen::Vector3d::UnitX(),
                                    Eigen::Vector3d::UnitY(), 0.2, 0.2, white()));
  const ShadingContext context{scene, SE3()};
  const SurfacePoint behind{Eigen::Vector3d(0.0, 0.0, 2.0), -Eigen::Vector3d::UnitZ(), 0};
  const SurfacePoint beside{Eigen::Vector3d(0.5, 0.0, 2.0), -Eigen::Vector3d::UnitZ(), 0};
  const ProjectorLight light(SE3(), pattern, o);
  EXPECT_EQ(light.illuminate(behind, context)[1], 0.0F);
  EXPECT_GT(light.illuminate(beside, context)[1], 0.0F);
  o.shadows = false;
  const ProjectorLight no_shadows(SE3(), pattern, o);
  EXPECT_GT(no_shadows.illuminate(behind, context)[1], 0.0F);

  // Rendered: the shadow of the occluder on the wall is dark in the dark room.
  Scene lit("shadow-render");
  lit.add(plane_at(2.0));
  const ProjectorOptions po = small_projector();
  lit.add(PlanarRect::from_corner(po.T_left_projector * Eigen::Vector3d(-0.1, -0.1, 1.0),
                                  Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), 0.2, 0.2,
                                  white()));
  const StereoFrame frame = render_active_stereo(lit, small_rig(), SE3(), pattern,
                                                 ProjectorMode::kDarkRoom, po, exact_render());
  // The wall point straight behind the occluder, seen from the left camera past its edge.
  const Eigen::Vector3d shadowed = po.T_left_projector * Eigen::Vector3d(0.0, 0.0, 2.0);
  const RectifiedStereo rig = small_rig();
  const int u = static_cast<int>(std::lround(rig.f * shadowed.x() / shadowed.z() + rig.cu));
  const int v = static_cast<int>(std::lround(rig.f * shadowed.y() / shadowed.z() + rig.cv));
  // The camera sees the occluder itself there (it lies on the camera's line of sight only if
  // the offsets line up), so check the depth tells the wall, then the brightness.
  if (std::abs(frame.left.depth_m.at<float>(v, u) - 2.0F) < 1e-3F) {
    EXPECT_EQ(frame.left.gray.at<float>(v, u), 0.0F);
  }
  EXPECT_GT(frame.left.gray.at<float>(5, 5), 50.0F);  // lit wall far from the shadow
}

TEST(Projector, FallOffIsInverseSquare) {
  ProjectorOptions o = small_projector();
  o.power = 0.7;
  o.reference_distance_m = 2.0;
  const cv::Mat pattern(o.height, o.width, CV_8UC3, cv::Scalar::all(255));
  const Scene empty("empty");
  const ShadingContext context{empty, SE3()};
  const ProjectorLight light(SE3(), pattern, o);
  for (const double d : {0.5, 1.0, 2.0, 3.0, 8.0}) {
    const SurfacePoint p{Eigen::Vector3d(0.0, 0.0, d), -Eigen::Vector3d::UnitZ(), 0};
    const double e = light.illuminate(p, context)[0];
    EXPECT_NEAR(e * d * d, o.power * o.reference_distance_m * o.reference_distance_m, 1e-5)
        << "d = " << d;
  }
  // Lambertian: a surface tilted by 60 degrees gets half.
  const SurfacePoint tilted{
      Eigen::Vector3d(0.0, 0.0, 2.0),
      Eigen::Vector3d(std::sin(std::numbers::pi / 3), 0.0, -std::cos(std::numbers::pi / 3)), 0};
  EXPECT_NEAR(light.illuminate(tilted, context)[2], 0.5 * o.power, 1e-5);
  // Behind the projector or outside its image: nothing.
  const SurfacePoint behind{Eigen::Vector3d(0.0, 0.0, -1.0), Eigen::Vector3d::UnitZ(), 0};
  EXPECT_EQ(light.illuminate(behind, context)[0], 0.0F);
  const SurfacePoint outside{Eigen::Vector3d(5.0, 0.0, 1.0), -Eigen::Vector3d::UnitZ(), 0};
  EXPECT_EQ(light.illuminate(outside, context)[0], 0.0F);
}

TEST(Projector, SameSeedGivesIdenticalImages) {
  const ProjectorOptions o = small_projector();
  sensor::PatternOptions po;
  po.width = o.width;
  po.height = o.height;
  po.lines = 40;
  const cv::Mat pattern = sensor::generate_pattern(po, 3);
  Scene scene("plane");
  scene.add(plane_at(2.0));
  RenderOptions render;
  render.noise.intensity_sigma = 2.0;
  auto frame = [&](std::uint64_t seed) {
    return render_active_stereo(scene, small_rig(), SE3(), pattern,
                                ProjectorMode::kAmbientAndPattern, o, render, seed);
  };
  const StereoFrame a = frame(5), b = frame(5), c = frame(6);
  EXPECT_EQ(cv::norm(a.left.color_bgr, b.left.color_bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right.color_bgr, b.right.color_bgr, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.left.color_bgr, c.left.color_bgr, cv::NORM_INF), 0.0);
}

// The left view without the rig lights, shaded in the same pass as the lit pair, is exactly
// the frame a separate renderer of the scene without the projector gives (with the same noise
// seed): the flight's tracking view costs no second render.
TEST(Projector, ViewWithoutRigLightsEqualsASeparateRender) {
  const Scene office = make_scene("office");
  ProjectorOptions o = small_projector();
  o.shadows = false;
  sensor::PatternOptions po;
  po.width = o.width;
  po.height = o.height;
  po.lines = 40;
  auto projector = std::make_shared<ProjectorLight>(SE3(), sensor::generate_pattern(po, 3), o);
  RenderOptions render;
  render.noise.intensity_sigma = 2.0;
  const RectifiedStereo rig = small_rig();
  StereoRenderer pair(rig, render, 11);
  pair.add_rig_light(projector);
  pair.reseed_left_without_rig_lights(99);
  Renderer separate(rig.left(), render, 99);
  // The projector as the scene's last light: the pair before the rig-light path existed.
  StereoRenderer scene_lit(rig, render, 11);
  const Scene lit_office =
      scene_with_projector(office, projector, ProjectorMode::kAmbientAndPattern);
  StereoFrame frame, reference;
  RenderedFrame unlit, expected;
  for (int k = 0; k < 3; ++k) {  // the noise streams stay in step over frames
    const SE3 T_world_left =
        office.T_world_start() *
        SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, 0.1 * k)), Eigen::Vector3d(0.1 * k, 0.0, 0.0)) *
        forward_camera_mount();
    projector->set_pose(T_world_left * o.T_left_projector);
    pair.render(office, T_world_left, frame, &unlit);
    separate.render(office, T_world_left, expected);
    scene_lit.render(lit_office, T_world_left, reference);
    EXPECT_EQ(cv::norm(unlit.color_bgr, expected.color_bgr, cv::NORM_INF), 0.0) << k;
    EXPECT_EQ(cv::norm(unlit.gray, expected.gray, cv::NORM_INF), 0.0) << k;
    EXPECT_EQ(cv::norm(frame.left.color_bgr, reference.left.color_bgr, cv::NORM_INF), 0.0) << k;
    EXPECT_EQ(cv::norm(frame.right.color_bgr, reference.right.color_bgr, cv::NORM_INF), 0.0) << k;
    // And the pattern is there in the lit view only.
    EXPECT_GT(cv::norm(frame.left.gray, unlit.gray, cv::NORM_L1) / unlit.gray.total(), 1.0) << k;
  }
}

TEST(Projector, BadInput) {
  ProjectorOptions o = small_projector();
  EXPECT_THROW(ProjectorLight(SE3(), cv::Mat(), o), InputError);
  EXPECT_THROW(ProjectorLight(SE3(), cv::Mat(10, 10, CV_8UC3), o), InputError);
  o.horizontal_fov_deg = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  EXPECT_THROW(parse_projector_mode("bright"), InputError);
}

}  // namespace
}  // namespace kestrel::sim
