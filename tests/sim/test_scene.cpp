// Scenes: primitives become the right faces, the slow-path ray query agrees with analytic
// intersections, and the named scenes exist (and unknown names are reported with the list).
#include <gtest/gtest.h>

#include <random>

#include "kestrel/core/error.hpp"
#include "kestrel/sim/scenes.hpp"

namespace kestrel::sim {
namespace {

Material grey() {
  return {std::make_shared<const Texture>(Texture::constant({0.5F, 0.5F, 0.5F})), {1, 1, 1}};
}

TEST(PlanarRect, FromCornerBuildsAnOrthonormalFrame) {
  const PlanarRect r = PlanarRect::from_corner({1, 2, 3}, {0, 2, 0}, {0, 0.5, 1}, 4.0, 2.0, grey());
  const Eigen::Matrix3d R = r.T_world_rect.rotation_matrix();
  EXPECT_LT((R.col(0) - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_LT((R.col(1) - Eigen::Vector3d::UnitZ()).norm(), 1e-12);  // made orthogonal to s
  EXPECT_LT((R.col(2) - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_LT((r.T_world_rect.translation() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  EXPECT_THROW((void)PlanarRect::from_corner({0, 0, 0}, {1, 0, 0}, {2, 0, 0}, 1, 1, grey()),
               std::invalid_argument);
}

TEST(Scene, BoxFacesPointOutwardAndCoverTheBox) {
  Scene scene;
  const SE3 T(SO3::exp({0.3, -0.2, 0.7}), {1.0, -2.0, 0.5});
  const Eigen::Vector3d h(0.3, 0.5, 0.7);
  EXPECT_EQ(scene.add(OrientedBox{T, h, grey()}), 0);
  ASSERT_EQ(scene.faces().size(), 6U);
  for (const Face& f : scene.faces()) {
    EXPECT_TRUE(f.one_sided);
    EXPECT_EQ(f.primitive, 0);
    EXPECT_LT(std::abs(f.axis_s.dot(f.axis_t)), 1e-12);
    // The face centre, in the box frame, lies on the box surface and the normal points away
    // from the box centre.
    const Eigen::Vector3d centre =
        f.origin_world + 0.5 * f.size_s_m * f.axis_s + 0.5 * f.size_t_m * f.axis_t;
    const Eigen::Vector3d local = T.inverse() * centre;
    EXPECT_NEAR((local.cwiseAbs() - h).cwiseAbs().minCoeff(), 0.0, 1e-12);
    EXPECT_GT(f.normal.dot(centre - T.translation()), 0.0);
  }
  EXPECT_THROW(scene.add(OrientedBox{T, {0.1, 0.0, 0.1}, grey()}), std::invalid_argument);
  EXPECT_THROW(scene.add(PlanarRect{SE3(), 1.0, 1.0, Material{}}), std::invalid_argument);
}

TEST(Scene, RayQueryMatchesAnalyticIntersections) {
  Scene scene;
  scene.add(InfinitePlane{SE3(), grey()});  // z = 0
  scene.add(OrientedBox{SE3(SO3(), {3.0, 0.0, 1.0}), {0.5, 0.5, 0.5}, grey()});
  // Straight down onto the plane.
  auto hit = scene.intersect({0.2, 0.3, 2.0}, {0.0, 0.0, -1.0});
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 2.0, 1e-12);
  EXPECT_EQ(hit->primitive, 0);
  EXPECT_LT((hit->n_world - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(hit->s_m, 0.2, 1e-12);
  EXPECT_NEAR(hit->t_m, 0.3, 1e-12);
  // From below the plane is seen too (two-sided), its normal facing the ray.
  hit = scene.intersect({0.0, 0.0, -1.0}, {0.0, 0.0, 2.0});
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 1.0, 1e-12);
  EXPECT_LT((hit->n_world + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  // Horizontally into the box: its near face at x = 2.5.
  hit = scene.intersect({0.0, 0.1, 1.2}, {1.0, 0.0, 0.0});
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 2.5, 1e-12);
  EXPECT_EQ(hit->primitive, 1);
  EXPECT_LT((hit->n_world + Eigen::Vector3d::UnitX()).norm(), 1e-12);
  // Nothing upwards; max_distance cuts.
  EXPECT_FALSE(scene.intersect({0.0, 0.0, 1.0}, {0.0, 0.0, 1.0}));
  EXPECT_FALSE(scene.intersect({0.0, 0.1, 1.2}, {1.0, 0.0, 0.0}, 1e-9, 2.4));
  // Occlusion: the box hides (5, 0, 1) from the origin side.
  EXPECT_TRUE(scene.occluded({0.0, 0.0, 1.0}, {5.0, 0.0, 1.0}));
  EXPECT_FALSE(scene.occluded({0.0, 0.0, 1.0}, {0.0, 3.0, 1.0}));
}

TEST(NamedScenes, AllBuildWithGeometryLightsAndAStartPose) {
  ASSERT_GE(scene_catalogue().size(), 4U);
  for (const auto& entry : scene_catalogue()) {
    const Scene scene = make_scene(entry.name);
    EXPECT_EQ(scene.name(), entry.name);
    EXPECT_FALSE(scene.description().empty());
    EXPECT_GE(scene.primitives().size(), 3U) << entry.name;
    EXPECT_FALSE(scene.lights().empty()) << entry.name;
    // The start pose is level (body z up) and looks along +x.
    const Eigen::Matrix3d R = scene.T_world_start().rotation_matrix();
    EXPECT_LT((R - Eigen::Matrix3d::Identity()).norm(), 1e-12) << entry.name;
    // Something lies ahead of the start pose.
    const auto hit = scene.intersect(scene.T_world_start().translation(), {1.0, 0.0, 0.0});
    ASSERT_TRUE(hit) << entry.name;
    EXPECT_GT(hit->distance, 0.5) << entry.name;
  }
}

TEST(NamedScenes, UnknownNameListsTheValidOnes) {
  try {
    (void)make_scene("ofice");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("ofice"), std::string::npos);
    for (const auto& entry : scene_catalogue()) {
      EXPECT_NE(what.find(std::string(entry.name)), std::string::npos) << what;
    }
  }
}

TEST(NamedScenes, TextureSeedChangesTexturesNotGeometry) {
  const Scene a = make_scene("wall", 0);
  const Scene b = make_scene("wall", 5);
  ASSERT_EQ(a.faces().size(), b.faces().size());
  for (std::size_t i = 0; i < a.faces().size(); ++i) {
    EXPECT_LT((a.faces()[i].origin_world - b.faces()[i].origin_world).norm(), 1e-15);
  }
  EXPECT_GT(cv::norm(a.faces()[0].material.texture->level(0),
                     b.faces()[0].material.texture->level(0), cv::NORM_INF),
            0.0);
}

}  // namespace
}  // namespace kestrel::sim
