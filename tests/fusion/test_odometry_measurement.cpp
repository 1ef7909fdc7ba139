// OdometryMeasurements: odometry results become the fusion's relative poses, from the
// keyframe (the motion and covariance the tracker reports) or from the previous tracked
// frame; failed and first frames, the names and their parsing.
#include <gtest/gtest.h>

#include <stdexcept>

#include "kestrel/fusion/odometry_measurement.hpp"

namespace kestrel::fusion {
namespace {

// The fields OdometryMeasurements reads, as odometry::TrackResult has them.
struct FakeTrack {
  TimeNs t_ns = 0;
  TimeNs ref_t_ns = 0;
  SE3 T_ref_cur;
  SE3 T_world_cam;
  Matrix6d covariance = Matrix6d::Identity();
  bool new_keyframe = false;
  bool failed = false;
  [[nodiscard]] bool ok() const { return !failed; }
};

SE3 pose(double x, double yaw) {
  return SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, yaw)), Eigen::Vector3d(x, 0.0, 0.0));
}

// A keyframe at t = 100 (world pose pose(1, 0.1)), frames at 200 and 300 aligned to it; the
// frame at 300 becomes the next keyframe.
std::vector<FakeTrack> sequence() {
  const SE3 T_w_kf = pose(1.0, 0.1);
  FakeTrack kf;
  kf.t_ns = 100;
  kf.ref_t_ns = 100;
  kf.T_world_cam = T_w_kf;
  kf.new_keyframe = true;
  FakeTrack a;
  a.t_ns = 200;
  a.ref_t_ns = 100;
  a.T_ref_cur = pose(0.2, 0.05);
  a.T_world_cam = T_w_kf * a.T_ref_cur;
  a.covariance = Vector6d::LinSpaced(1e-6, 6e-6).asDiagonal();
  FakeTrack b = a;
  b.t_ns = 300;
  b.T_ref_cur = pose(0.5, 0.08);
  b.T_world_cam = T_w_kf * b.T_ref_cur;
  b.covariance = 2.0 * a.covariance;
  b.new_keyframe = true;
  return {kf, a, b};
}

TEST(OdometryMeasurements, KeyframeReferenceGivesTheMotionFromTheKeyframe) {
  const auto s = sequence();
  OdometryMeasurements meas(OdometryReference::kKeyframe, 25.0);
  const auto m0 = meas.next(s[0]);  // first frame: clone only
  ASSERT_TRUE(m0);
  EXPECT_EQ(m0->t_ref_ns, 100);
  EXPECT_TRUE(m0->starts_new_reference);
  const auto m1 = meas.next(s[1]);
  ASSERT_TRUE(m1);
  EXPECT_EQ(m1->t_ref_ns, 100);
  EXPECT_LT((m1->T_ref_cur.log() - s[1].T_ref_cur.log()).norm(), 1e-15);
  EXPECT_LT((m1->covariance - 25.0 * s[1].covariance).norm(), 1e-18);
  EXPECT_FALSE(m1->starts_new_reference);  // the keyframe is kept: so is the filter's clone
  const auto m2 = meas.next(s[2]);
  ASSERT_TRUE(m2);
  EXPECT_EQ(m2->t_ref_ns, 100);  // still from the old keyframe ...
  EXPECT_LT((m2->T_ref_cur.log() - s[2].T_ref_cur.log()).norm(), 1e-15);
  EXPECT_TRUE(m2->starts_new_reference);  // ... and the clone moves to this frame
}

TEST(OdometryMeasurements, PreviousFrameReferenceGivesTheMotionSinceTheLastTrackedFrame) {
  const auto s = sequence();
  OdometryMeasurements meas(OdometryReference::kPreviousFrame, 25.0);
  (void)meas.next(s[0]);
  (void)meas.next(s[1]);
  const auto m2 = meas.next(s[2]);
  ASSERT_TRUE(m2);
  EXPECT_EQ(m2->t_ref_ns, 200);
  const SE3 expected = s[1].T_world_cam.inverse() * s[2].T_world_cam;
  EXPECT_LT((m2->T_ref_cur.log() - expected.log()).norm(), 1e-12);
  EXPECT_LT((m2->covariance - 25.0 * s[2].covariance).norm(), 1e-18);
  EXPECT_TRUE(m2->starts_new_reference);
  // A failed frame gives nothing; the next one is measured from the last tracked frame.
  FakeTrack failed = s[2];
  failed.t_ns = 400;
  failed.failed = true;
  EXPECT_FALSE(meas.next(failed));
  FakeTrack after = s[2];
  after.t_ns = 500;
  const auto m5 = meas.next(after);
  ASSERT_TRUE(m5);
  EXPECT_EQ(m5->t_ref_ns, 300);
  // reset(): the next one only starts a reference.
  meas.reset();
  const auto m6 = meas.next(after);
  ASSERT_TRUE(m6);
  EXPECT_EQ(m6->t_ref_ns, m6->t_ns);
}

TEST(OdometryMeasurements, AFailedFrameOnlyMovesTheCloneWithTheKeyframeReference) {
  FakeTrack failed;
  failed.t_ns = 500;
  failed.ref_t_ns = 100;
  failed.T_ref_cur = pose(9.0, 0.0);  // the prediction: not a measurement
  failed.failed = true;
  OdometryMeasurements meas(OdometryReference::kKeyframe, 25.0);
  const auto m = meas.next(failed);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->t_ref_ns, 500);
  EXPECT_EQ(m->t_ns, 500);
  EXPECT_TRUE(m->starts_new_reference);
  EXPECT_LT(m->T_ref_cur.log().norm(), 1e-15);
}

TEST(OdometryMeasurements, NamesRoundTripAndUnknownNamesAreRefused) {
  for (const auto r : {OdometryReference::kKeyframe, OdometryReference::kPreviousFrame}) {
    EXPECT_EQ(parse_odometry_reference(odometry_reference_name(r)), r);
  }
  try {
    (void)parse_odometry_reference("previous");
    FAIL() << "accepted an unknown name";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe, previous_frame"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace kestrel::fusion
