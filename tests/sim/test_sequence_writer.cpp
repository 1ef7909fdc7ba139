// Rendered sequences on disk: written in the TUM RGB-D and EuRoC layouts and read back with
// Kestrel's own readers (files, counts, 16-bit depth at 5000 per metre, ground truth).
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/sequence_writer.hpp"
#include "test_data.hpp"

namespace kestrel::sim {
namespace {

namespace fs = std::filesystem;

PinholeCamera tiny_camera() { return PinholeCamera({60.0, 60.0, 39.5, 29.5, 80, 60}); }

std::size_t count_files(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

/// Renders `frames` frames of the checker scene along "sway" into `dir`.
void write_sequence(const fs::path& dir, std::size_t frames, bool stereo, bool force = false) {
  const Scene scene = make_scene("checker");
  const SmoothTrajectory traj = make_trajectory("sway", scene.T_world_start());
  SequenceLayout layout;
  layout.camera = tiny_camera();
  layout.rate_hz = 30.0;
  if (stereo) layout.stereo = RectifiedStereo{60.0, 39.5, 29.5, 0.1, 80, 60};
  SequenceWriter writer(dir, layout, force);
  const FrameClock clock = FrameClock::from_rate(layout.rate_hz);
  Renderer renderer(layout.camera);
  StereoRenderer stereo_renderer(layout.stereo ? *layout.stereo
                                               : RectifiedStereo{1, 0, 0, 1, 1, 1});
  RenderedFrame frame;
  StereoFrame stereo_frame;
  for (std::size_t k = 0; k < frames; ++k) {
    const TimeNs t = clock.time_ns(k);
    const KinematicState body = traj.state(clock.trajectory_time_s(t));
    const SE3 T_world_cam = body.T_world_body * layout.T_body_cam;
    if (stereo) {
      stereo_renderer.render(scene, T_world_cam, stereo_frame);
      writer.write(t, body, stereo_frame);
    } else {
      renderer.render(scene, T_world_cam, frame);
      writer.write(t, body, frame);
    }
  }
  writer.finish();
  EXPECT_EQ(writer.frames_written(), frames);
}

TEST(FrameClock, StartsAtTheEpochInWholePeriods) {
  const FrameClock c = FrameClock::from_rate(30.0);
  EXPECT_EQ(c.epoch_ns, 1'000'000'000);
  EXPECT_EQ(c.period_ns, 33'333'333);
  EXPECT_EQ(c.time_ns(3), 1'099'999'999);
  EXPECT_DOUBLE_EQ(c.trajectory_time_s(c.time_ns(30)), 0.99999999);
  EXPECT_THROW((void)FrameClock::from_rate(0.0), std::invalid_argument);
}

TEST(SequenceWriter, DepthPngIsFiveThousandUnitsPerMetre) {
  cv::Mat depth(1, 5, CV_32F);
  depth.at<float>(0, 0) = 1.0F;
  depth.at<float>(0, 1) = 2.00005F;  // rounds to 10000.25 -> 10000
  depth.at<float>(0, 2) = 0.0F;      // no depth
  depth.at<float>(0, 3) = 13.2F;     // beyond 16 bits
  depth.at<float>(0, 4) = 0.12345F;
  const cv::Mat png = depth_to_png16(depth);
  ASSERT_EQ(png.type(), CV_16U);
  EXPECT_EQ(png.at<std::uint16_t>(0, 0), 5000);
  EXPECT_EQ(png.at<std::uint16_t>(0, 1), 10000);
  EXPECT_EQ(png.at<std::uint16_t>(0, 2), 0);
  EXPECT_EQ(png.at<std::uint16_t>(0, 3), 0);
  EXPECT_EQ(png.at<std::uint16_t>(0, 4), 617);
}

TEST(SequenceWriter, TumSequenceReadsBackWithItsDepthAndGroundTruth) {
  const fs::path dir = test::fresh_temp_dir("seq_tum") / "out";
  write_sequence(dir, 4, false);
  EXPECT_EQ(count_files(dir / "rgb"), 4U);
  EXPECT_EQ(count_files(dir / "depth"), 4U);
  EXPECT_TRUE(fs::exists(dir / "camera.yaml"));
  EXPECT_FALSE(fs::exists(dir / "mav0"));
  // The first line of every list is the provenance line.
  std::ifstream rgb(dir / "rgb.txt");
  std::string first;
  std::getline(rgb, first);
  EXPECT_EQ(first, "# written by kestrel render");

  const io::TumRgbdSequence seq(dir);
  ASSERT_EQ(seq.size(), 4U);
  EXPECT_EQ(seq.timestamp(0), 1'000'000'000);
  EXPECT_EQ(seq.timestamp(3), 1'000'000'000 + 3 * 33'333'333);
  const auto gt = seq.groundtruth();
  ASSERT_TRUE(gt);
  ASSERT_EQ(gt->size(), 4U);

  // Re-render frame 2 and compare with what is on disk.
  const Scene scene = make_scene("checker");
  const SmoothTrajectory traj = make_trajectory("sway", scene.T_world_start());
  const FrameClock clock = FrameClock::from_rate(30.0);
  const SE3 T_world_cam =
      traj.T_world_body(clock.trajectory_time_s(clock.time_ns(2))) * forward_camera_mount();
  Renderer renderer(tiny_camera());
  const RenderedFrame frame = renderer.render(scene, T_world_cam);
  const io::RgbdImages images = seq.load(2);
  EXPECT_EQ(cv::norm(images.bgr, frame.color_bgr, cv::NORM_INF), 0.0);
  const cv::Mat raw =
      cv::imread((dir / "depth" / "1.066666666.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16U);
  for (int v = 0; v < raw.rows; v += 5) {
    for (int u = 0; u < raw.cols; u += 5) {
      const float z = frame.depth_m.at<float>(v, u);
      EXPECT_EQ(raw.at<std::uint16_t>(v, u),
                static_cast<int>(std::lround(static_cast<double>(z) * 5000.0)));
      EXPECT_NEAR(images.depth_m.at<float>(v, u), z, 0.5 / 5000.0 + 1e-6);
    }
  }
  // Ground truth is T_world_cam of the rendered camera.
  EXPECT_EQ((*gt)[2].t_ns, clock.time_ns(2));
  EXPECT_LT(((*gt)[2].T_world_body.translation() - T_world_cam.translation()).norm(), 1e-9);
  EXPECT_LT(((*gt)[2].T_world_body.so3().inverse() * T_world_cam.so3()).log().norm(), 1e-9);
}

TEST(SequenceWriter, StereoSequenceReadsBackAsEuroc) {
  const fs::path dir = test::fresh_temp_dir("seq_euroc") / "out";
  write_sequence(dir, 3, true);
  const io::EurocSequence seq(dir);
  ASSERT_EQ(seq.stereo_size(), 3U);
  EXPECT_EQ(seq.stereo_timestamp(1), 1'033'333'333);
  const io::StereoImages pair = seq.load_stereo(0);
  EXPECT_EQ(pair.left.type(), CV_8UC1);
  EXPECT_EQ(pair.left.cols, 80);
  EXPECT_GT(cv::norm(pair.left, pair.right, cv::NORM_L1), 0.0);
  const io::CameraFile cam0 = seq.cam0_calibration();
  const io::CameraFile cam1 = seq.cam1_calibration();
  EXPECT_DOUBLE_EQ(cam0.camera.fx(), 60.0);
  ASSERT_TRUE(cam0.T_body_sensor && cam1.T_body_sensor);
  // cam1 sits at +baseline along cam0's x.
  const SE3 T_cam0_cam1 = cam0.T_body_sensor->inverse() * *cam1.T_body_sensor;
  EXPECT_LT((T_cam0_cam1.translation() - Eigen::Vector3d(0.1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((cam0.T_body_sensor->translation()).norm(), 1e-12);
  const RectifiedStereo rig = io::load_rectified_stereo(dir / "stereo.yaml");
  EXPECT_DOUBLE_EQ(rig.baseline_m, 0.1);
  EXPECT_EQ(count_files(dir / "mav0" / "cam0" / "disparity"), 3U);
  // The full-state ground truth (17 columns, with velocities) of the body.
  const auto gt_csv = seq.groundtruth_csv();
  ASSERT_TRUE(gt_csv);
  const auto states = io::read_euroc_state_groundtruth(*gt_csv);
  ASSERT_EQ(states.size(), 3U);
  const SmoothTrajectory traj = make_trajectory("sway", make_scene("checker").T_world_start());
  const KinematicState s = traj.state(ns_to_s(states[2].t_ns - FrameClock::kDefaultEpochNs));
  EXPECT_LT((states[2].v_world - s.v_world).norm(), 1e-12);
  EXPECT_LT((states[2].T_world_body.translation() - s.T_world_body.translation()).norm(), 1e-12);
  // The RGB-D sequence is the left view.
  EXPECT_EQ(io::TumRgbdSequence(dir).size(), 3U);
}

TEST(SequenceWriter, RerunReplacesFramesAndForeignFoldersAreRefused) {
  const fs::path root = test::fresh_temp_dir("seq_rerun");
  const fs::path dir = root / "out";
  write_sequence(dir, 4, true);
  write_sequence(dir, 2, false);  // same command: allowed; stale frames and mav0/ go
  EXPECT_EQ(count_files(dir / "rgb"), 2U);
  EXPECT_EQ(count_files(dir / "depth"), 2U);
  EXPECT_FALSE(fs::exists(dir / "mav0"));
  EXPECT_EQ(io::TumRgbdSequence(dir).size(), 2U);

  const fs::path foreign = root / "foreign";
  fs::create_directories(foreign);
  std::ofstream(foreign / "notes.txt") << "mine\n";
  EXPECT_THROW(write_sequence(foreign, 1, false), InputError);
  write_sequence(foreign, 1, false, /*force=*/true);
  EXPECT_TRUE(fs::exists(foreign / "notes.txt"));  // --force writes, it does not clean up
}

TEST(SequenceWriter, RejectsMismatchedFramesAndLayouts) {
  const fs::path dir = test::fresh_temp_dir("seq_bad") / "out";
  SequenceLayout layout;
  layout.camera = tiny_camera();
  SequenceWriter writer(dir, layout);
  const Scene scene = make_scene("checker");
  Renderer wrong(PinholeCamera({60.0, 60.0, 39.5, 29.5, 40, 30}));
  const KinematicState body;
  EXPECT_THROW(writer.write(1, body, wrong.render(scene, SE3())), std::invalid_argument);
  StereoFrame stereo;
  EXPECT_THROW(writer.write(1, body, stereo), std::logic_error);
  Renderer right(tiny_camera());
  writer.write(5, body, right.render(scene, SE3()));
  EXPECT_THROW(writer.write(5, body, right.render(scene, SE3())), std::invalid_argument);
  writer.finish();
  EXPECT_THROW(writer.write(9, body, right.render(scene, SE3())), std::logic_error);
}

}  // namespace
}  // namespace kestrel::sim
