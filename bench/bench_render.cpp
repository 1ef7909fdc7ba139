// Renderer benchmarks: one 640x480 frame (ROS default camera) of each named scene from its
// start pose, with and without sensor noise, a stereo pair, and building a scene.
#include <benchmark/benchmark.h>

#include <string>

#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace {

using namespace kestrel;

const char* const kScenes[] = {"office", "corridor", "wall", "checker"};

PinholeCamera ros_camera() { return PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480}); }

void render_scene(benchmark::State& state, const sim::RenderOptions& options) {
  const sim::Scene scene = sim::make_scene(kScenes[state.range(0)]);
  state.SetLabel(scene.name());
  sim::Renderer renderer(ros_camera(), options);
  sim::RenderedFrame frame;
  const sim::SmoothTrajectory traj = sim::make_trajectory("handheld", scene.T_world_start());
  double t = 0.0;
  for (auto _ : state) {
    renderer.render(scene, traj.T_world_body(t) * sim::forward_camera_mount(), frame);
    benchmark::DoNotOptimize(frame.gray.data);
    t += 1.0 / 30.0;
  }
  state.counters["edge_px"] = static_cast<double>(renderer.edge_pixels());
}

void BM_Render640x480(benchmark::State& state) { render_scene(state, {}); }
BENCHMARK(BM_Render640x480)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

void BM_Render640x480KinectNoise(benchmark::State& state) {
  sim::RenderOptions options;
  options.noise = sim::SensorNoiseOptions::kinect();
  render_scene(state, options);
}
BENCHMARK(BM_Render640x480KinectNoise)->Arg(0)->Unit(benchmark::kMillisecond);

void BM_Render640x480NoEdgeSupersampling(benchmark::State& state) {
  sim::RenderOptions options;
  options.edge_supersampling = 1;
  render_scene(state, options);
}
BENCHMARK(BM_Render640x480NoEdgeSupersampling)->Arg(0)->Unit(benchmark::kMillisecond);

void BM_RenderStereo640x480(benchmark::State& state) {
  const sim::Scene scene = sim::make_scene(kScenes[state.range(0)]);
  state.SetLabel(scene.name());
  sim::StereoRenderer renderer(RectifiedStereo{525.0, 319.5, 239.5, 0.1, 640, 480});
  sim::StereoFrame frame;
  const SE3 T = scene.T_world_start() * sim::forward_camera_mount();
  for (auto _ : state) {
    renderer.render(scene, T, frame);
    benchmark::DoNotOptimize(frame.disparity_px.data);
  }
}
BENCHMARK(BM_RenderStereo640x480)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_MakeScene(benchmark::State& state) {
  for (auto _ : state) {
    sim::Scene scene = sim::make_scene(kScenes[state.range(0)]);
    benchmark::DoNotOptimize(scene.faces().data());
  }
  state.SetLabel(kScenes[state.range(0)]);
}
BENCHMARK(BM_MakeScene)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

}  // namespace
