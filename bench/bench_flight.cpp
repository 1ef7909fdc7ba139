// The closed loop's per-frame and per-step costs: one camera frame of the on-board vision
// (render the active-stereo pair and the tracking view, match, track) split by stage (wall
// time) with the process CPU time per frame over all threads, and the
// IMU output predictor over a 50 ms filter lag at 1 kHz.
#include <benchmark/benchmark.h>

#include <ctime>

#include "kestrel/flight/imu_forward_predictor.hpp"
#include "kestrel/flight/stereo_vision.hpp"
#include "kestrel/sim/scenes.hpp"

namespace {

using namespace kestrel;

// A slow sway of the body in front of the office's start pose: every frame moves a little.
SE3 sway_pose(const SE3& start, int frame) {
  const double t = frame / 30.0;
  return start * SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, 0.05 * std::sin(t))),
                     Eigen::Vector3d(0.0, 0.2 * std::sin(0.7 * t), 0.05 * std::sin(1.3 * t)));
}

void BM_StereoVisionFrame(benchmark::State& state) {
  const char* scene_name = state.range(0) == 0 ? "office" : "corridor";
  const sim::Scene scene = sim::make_scene(scene_name);
  flight::StereoVision vision(scene, flight::StereoVisionOptions{}, 1);
  int frame = 0;
  double render = 0.0, match = 0.0, track = 0.0;
  std::size_t tracked = 0;
  // Process CPU time, all threads: what one core would have to do per frame.
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) {
    const flight::VisionFrame f =
        vision.process(s_to_ns(frame / 30.0), sway_pose(scene.T_world_start(), frame));
    render += f.render_ms;
    match += f.match_ms;
    track += f.track_ms;
    tracked += f.track.ok() ? 1 : 0;
    ++frame;
  }
  state.SetLabel(scene_name);
  const double n = static_cast<double>(frame);
  state.counters["render_ms"] = render / n;
  state.counters["stereo_ms"] = match / n;
  state.counters["odometry_ms"] = track / n;
  state.counters["tracked_pct"] = 100.0 * static_cast<double>(tracked) / n;
  state.counters["process_cpu_ms"] =
      1e3 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC / n;
}
BENCHMARK(BM_StereoVisionFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(3.0);

void BM_ImuForwardPredictor50ms(benchmark::State& state) {
  flight::ImuForwardPredictor predictor;
  fusion::FusedState fused;
  predictor.set_fused(fused);
  for (int k = 1; k <= 50; ++k) {
    io::ImuSample s;
    s.t_ns = k * 1'000'000;
    s.gyro_rad_s = Eigen::Vector3d(0.01, -0.02, 0.1);
    s.accel_m_s2 = Eigen::Vector3d(0.1, 0.0, 9.81);
    predictor.add_imu(s);
  }
  for (auto _ : state) {
    auto e = predictor.predict();
    benchmark::DoNotOptimize(e);
  }
}
BENCHMARK(BM_ImuForwardPredictor50ms)->Unit(benchmark::kMicrosecond);

}  // namespace
