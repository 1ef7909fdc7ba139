// keyframe_measurement(): an odometry result becomes the motion from its keyframe with the
// covariance reported for that motion; failed and first frames only move the clone.
#include <gtest/gtest.h>

#include "kestrel/fusion/odometry_measurement.hpp"

namespace kestrel::fusion {
namespace {

// The fields keyframe_measurement() reads, as odometry::TrackResult has them.
struct FakeTrack {
  TimeNs t_ns = 0;
  TimeNs ref_t_ns = 0;
  SE3 T_ref_cur;
  Matrix6d covariance = Matrix6d::Identity();
  bool new_keyframe = false;
  bool failed = false;
  [[nodiscard]] bool ok() const { return !failed; }
};

TEST(KeyframeMeasurement, IsTheMotionFromTheKeyframeWithItsScaledCovariance) {
  FakeTrack r;
  r.t_ns = 300;
  r.ref_t_ns = 100;
  r.T_ref_cur = SE3(SO3::exp(Eigen::Vector3d(0.0, 0.1, 0.0)), Eigen::Vector3d(0.2, 0.0, 0.0));
  r.covariance = Vector6d::LinSpaced(1e-6, 6e-6).asDiagonal();
  const RelativePoseMeasurement m = keyframe_measurement(r, 25.0);
  EXPECT_EQ(m.t_ns, 300);
  EXPECT_EQ(m.t_ref_ns, 100);
  EXPECT_LT((m.T_ref_cur.log() - r.T_ref_cur.log()).norm(), 1e-15);
  EXPECT_LT((m.covariance - 25.0 * r.covariance).norm(), 1e-18);
  EXPECT_FALSE(m.starts_new_reference);  // the keyframe is kept: so is the filter's clone

  r.new_keyframe = true;
  EXPECT_TRUE(keyframe_measurement(r, 1.0).starts_new_reference);
}

TEST(KeyframeMeasurement, FailedAndFirstFramesOnlyStartAReference) {
  FakeTrack failed;
  failed.t_ns = 500;
  failed.ref_t_ns = 100;
  failed.T_ref_cur =
      SE3(SO3(), Eigen::Vector3d(9.0, 0.0, 0.0));  // the prediction: not a measurement
  failed.failed = true;
  FakeTrack first;
  first.t_ns = 700;
  first.ref_t_ns = 700;
  first.new_keyframe = true;
  for (const FakeTrack& r : {failed, first}) {
    const RelativePoseMeasurement m = keyframe_measurement(r, 25.0);
    EXPECT_EQ(m.t_ref_ns, r.t_ns);
    EXPECT_EQ(m.t_ns, r.t_ns);
    EXPECT_TRUE(m.starts_new_reference);
    EXPECT_LT(m.T_ref_cur.log().norm(), 1e-15);
  }
}

}  // namespace
}  // namespace kestrel::fusion
