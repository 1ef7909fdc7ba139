// `kestrel render`: renders a synthetic RGB-D (and optionally stereo) sequence of a named
// scene along a named trajectory, in the TUM RGB-D and EuRoC layouts.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/sequence_writer.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"
#include "option_checks.hpp"
#include "progress.hpp"

namespace kestrel::cli {

namespace {

struct RenderArgs {
  std::string scene;
  std::string trajectory;
  std::string out;
  std::uint64_t seed = 1;
  std::uint64_t texture_seed = 0;
  std::size_t frames = 90;
  double duration_s = 0.0;
  double rate_hz = 30.0;
  std::string camera = "ros";
  std::string noise = "none";
  std::string render_options;
  bool stereo = false;
  double baseline_m = 0.1;
  bool force = false;
  bool list = false;
};

void print_catalogues(std::ostream& os) {
  os << "scenes (--scene):\n";
  for (const auto& e : sim::scene_catalogue()) {
    os << "  " << std::left << std::setw(15) << e.name << e.description << "\n";
  }
  os << "trajectories (--trajectory):\n";
  for (const auto& e : sim::trajectory_catalogue()) {
    os << "  " << std::left << std::setw(15) << e.name << e.description << "\n";
  }
  os << "noise models (--noise): none, kinect, or a YAML file of SensorNoiseOptions fields\n";
}

void run_render(const RenderArgs& a) {
  if (a.list) {
    print_catalogues(std::cout);
    return;
  }
  if (a.scene.empty() || a.trajectory.empty() || a.out.empty()) {
    throw InputError(
        "render: --scene, --trajectory and --out are required (--list shows the "
        "scenes and trajectories)");
  }
  if (!(a.rate_hz > 0.0) || !std::isfinite(a.rate_hz)) {
    throw InputError("render: --rate must be positive");
  }
  if (a.stereo && !(a.baseline_m > 0.0)) throw InputError("render: --baseline must be positive");

  // Names first (cheap, and the errors list the valid names), then the scene.
  (void)sim::make_trajectory(a.trajectory, SE3(), a.seed);
  const sim::Scene scene = sim::make_scene(a.scene, a.texture_seed);
  const sim::SmoothTrajectory trajectory =
      sim::make_trajectory(a.trajectory, scene.T_world_start(), a.seed);

  PinholeCamera camera = io::load_camera(a.camera);
  std::string camera_note;
  if (camera.has_distortion()) {
    camera = camera.without_distortion();
    camera_note = " (distortion dropped: rendered images are distortion-free)";
  }
  sim::RenderOptions options;
  if (!a.render_options.empty()) options = sim::RenderOptions::load_yaml(a.render_options);
  options.noise = sim::SensorNoiseOptions::from_name_or_file(a.noise);

  const std::size_t frames =
      a.duration_s > 0.0
          ? static_cast<std::size_t>(std::max(1LL, std::llround(a.duration_s * a.rate_hz)))
          : a.frames;
  if (frames == 0) throw InputError("render: --frames must be at least 1");
  const sim::FrameClock clock = sim::FrameClock::from_rate(a.rate_hz);

  sim::SequenceLayout layout;
  layout.camera = camera;
  layout.T_body_cam = sim::forward_camera_mount();
  layout.rate_hz = a.rate_hz;
  if (a.stereo) {
    if (camera.fx() != camera.fy()) {
      throw InputError(
          "render: --stereo needs a camera with fx == fy (a rectified pair "
          "shares one focal length); got fx " +
          std::to_string(camera.fx()) + ", fy " + std::to_string(camera.fy()));
    }
    layout.stereo = RectifiedStereo{camera.fx(),  camera.cx(),    camera.cy(),
                                    a.baseline_m, camera.width(), camera.height()};
  }

  std::ostringstream log;
  log << "kestrel render\n"
      << "  scene:      " << scene.name() << " (texture seed " << a.texture_seed << ")\n"
      << "  trajectory: " << trajectory.name() << " (seed " << a.seed << ")\n"
      << "  frames:     " << frames << " at " << a.rate_hz << " Hz ("
      << static_cast<double>(frames) / a.rate_hz << " s), first time stamp "
      << io::format_seconds(clock.epoch_ns) << " s\n"
      << "  camera:     " << camera.describe() << camera_note << "\n"
      << "  stereo:     ";
  if (a.stereo) {
    log << "baseline " << a.baseline_m << " m, f " << camera.fx() << " px";
  } else {
    log << "off";
  }
  log << "\n"
      << "  render:     " << options.describe() << "\n"
      << "  output:     " << a.out << "\n";
  std::cout << log.str() << std::flush;

  {
    io::OutputGuard outputs(sim::SequenceWriter::kCommand, a.force);
    for (const auto& [option, value] : {std::pair{"--camera", a.camera},
                                        {"--noise", a.noise},
                                        {"--render-options", a.render_options}}) {
      if (std::filesystem::is_regular_file(value)) outputs.input(option, value);
    }
    outputs.folder("--out", a.out);
  }
  sim::SequenceWriter writer(a.out, layout, a.force);
  {
    const std::filesystem::path info = std::filesystem::path(a.out) / "render.txt";
    io::check_can_write_file(info, sim::SequenceWriter::kCommand, true);
    std::ofstream out(info);
    out << io::provenance_line(sim::SequenceWriter::kCommand) << "\n" << log.str();
    if (!out) throw InputError(info.string() + ": cannot write");
    options.noise.save_yaml(std::filesystem::path(a.out) / "noise.yaml",
                            sim::SequenceWriter::kCommand, true);
  }

  std::optional<sim::Renderer> mono;
  std::optional<sim::StereoRenderer> stereo;
  if (layout.stereo) {
    stereo.emplace(*layout.stereo, options, a.seed);
  } else {
    mono.emplace(camera, options, a.seed);
  }
  sim::RenderedFrame frame;
  sim::StereoFrame stereo_frame;
  const InterruptScope interrupt;  // Ctrl-C: the frames rendered so far form a sequence
  ProgressBar progress("render", frames);
  double render_s = 0.0;
  std::size_t written = 0;
  for (std::size_t k = 0; k < frames && !interrupt.requested(); ++k) {
    const TimeNs t_ns = clock.time_ns(k);
    const sim::KinematicState body = trajectory.state(clock.trajectory_time_s(t_ns));
    const SE3 T_world_cam = body.T_world_body * layout.T_body_cam;
    const auto start = std::chrono::steady_clock::now();
    if (stereo) {
      stereo->render(scene, T_world_cam, stereo_frame);
    } else {
      mono->render(scene, T_world_cam, frame);
    }
    render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stereo) {
      writer.write(t_ns, body, stereo_frame);
    } else {
      writer.write(t_ns, body, frame);
    }
    written = k + 1;
    progress.update(written);
  }
  writer.finish();
  progress.finish();
  if (interrupt.requested()) {
    throw_interrupted(interrupt, "after " + std::to_string(written) + " of " +
                                     std::to_string(frames) + " frames; wrote them to " + a.out +
                                     " (a complete sequence of " + std::to_string(written) +
                                     " frames)");
  }
  std::cout << "wrote " << frames << " frames to " << a.out << " (rendering "
            << std::setprecision(3) << 1e3 * render_s / static_cast<double>(frames) << " ms per "
            << (stereo ? "stereo pair" : "frame") << ")\n";
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a synthetic RGB-D sequence (TUM layout) and optionally a rectified stereo "
      "sequence (EuRoC layout) of a named scene along a named trajectory");
  cmd->add_option("--scene", args->scene, "Scene name (see --list)");
  cmd->add_option("--trajectory", args->trajectory, "Trajectory name (see --list)");
  cmd->add_option("--out", args->out, "Output folder (created; refused if it holds other files)");
  cmd->add_option("--seed", args->seed, "Seed of the sensor noise and random trajectories")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  cmd->add_option("--texture-seed", args->texture_seed,
                  "Seed of the scene's random textures (0: the canonical scene)")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  auto* frames = cmd->add_option("--frames", args->frames, "Number of frames")
                     ->capture_default_str()
                     ->check(whole_in(1, 100000, "a whole number of frames, 1 to 100000"));
  auto* duration =
      cmd->add_option("--duration", args->duration_s, "Length in seconds (instead of --frames)")
          ->check(number_in(0.0, 3600.0, "a duration in (0, 3600] s", true));
  frames->excludes(duration);
  cmd->add_option("--rate", args->rate_hz, "Frame rate in Hz")
      ->capture_default_str()
      ->check(number_in(0.0, 1000.0, "a rate in (0, 1000] Hz", true));
  cmd->add_option("--camera", args->camera,
                  "Camera preset (fr1, fr2, fr3, ros) or camera YAML file")
      ->capture_default_str();
  cmd->add_option("--noise", args->noise, "Sensor noise: none, kinect, or a YAML file")
      ->capture_default_str();
  cmd->add_option("--render-options", args->render_options,
                  "YAML file of render options (near_m, far_m, edge_supersampling, "
                  "mipmapping, noise)");
  cmd->add_flag("--stereo", args->stereo,
                "Also write a rectified stereo sequence (mav0/, EuRoC layout) and stereo.yaml");
  cmd->add_option("--baseline", args->baseline_m, "Stereo baseline in metres")
      ->capture_default_str()
      ->check(number_in(0.0, 10.0, "a baseline in (0, 10] m", true));
  cmd->add_flag("--force", args->force, "Write into a folder that holds other files");
  cmd->add_flag("--list", args->list, "List the scenes and trajectories, then exit");
  cmd->callback([args] { run_render(*args); });
}

}  // namespace kestrel::cli
