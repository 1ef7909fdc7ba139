// The stages of the real-time pipeline and their wiring (see pipeline.hpp and docs/pipeline.md).
#include "kestrel/pipeline/pipeline.hpp"

#include <algorithm>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>
#include <variant>

#include "camera_source.hpp"
#include "controller_stage.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/pipeline/bounded_queue.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"

namespace kestrel::pipeline {

namespace {

// What travels between the stages. Every item carries its capture time (data time) and the
// steady-clock time its image pair entered the pipeline, from which latencies are measured.
struct FrameItem {
  TimeNs t_ns = 0;
  Clock::time_point arrived;
  cv::Mat left, right;
};
struct DisparityItem {
  TimeNs t_ns = 0;
  Clock::time_point arrived;
  sensor::StereoDepthFrame frame;  // fresh buffers per frame: shared read-only downstream
};
struct TrackItem {
  TimeNs t_ns = 0;
  Clock::time_point arrived;
  // The relative motion for the fusion (fusion::OdometryMeasurements::next()) and the
  // tracker's pose; none when tracking failed.
  std::optional<fusion::RelativePoseMeasurement> measurement;
  std::optional<SE3> T_world_cam;
};
using FusionInput = std::variant<io::ImuSample, TrackItem>;
struct StateItem {
  fusion::FusedState state;
  Clock::time_point arrived;
};

// Everything the stage threads share. A stage that throws stores the first exception and
// closes every queue, so that the others finish instead of waiting forever.
struct Context {
  const PipelineOptions& options;
  const std::atomic<bool>* stop;
  const io::EurocSequence* sequence;  // folder source, else null
  CameraFrameSource* camera;          // camera source, else null
  std::ostream* log;                  // the camera's problem frames
  std::size_t frames = 0;             // folder source: pairs to emit
  sensor::StereoFrontEnd& front_end;
  odometry::DirectTracker& tracker;
  fusion::FusionOptions fusion_options;

  BoundedQueue<FrameItem> frame_q;
  BoundedQueue<DisparityItem> disparity_q;
  BoundedQueue<FusionInput> fusion_q;
  BoundedQueue<StateItem> state_q;
  // Source (IMU; a camera source sends none but closes its share too) and tracker.
  std::atomic<int> fusion_producers{2};
  std::atomic<bool> abort{false};
  std::mutex error_mutex;
  std::exception_ptr error;

  std::size_t imu_samples = 0;
  std::size_t stereo_pairs = 0;
  std::size_t matched_pairs = 0;  // depth stage only
  double fill_sum = 0.0;          // depth stage only: the pairs' disparity fill
  fusion::FusionCounters fusion_counters;
  std::vector<fusion::FusedState> states;
  std::vector<ControllerRecord> controller_records;
  std::optional<driver::CaptureReport> camera_report;

  Context(const PipelineOptions& o, const std::atomic<bool>* s, const io::EurocSequence* seq,
          CameraFrameSource* cam, std::ostream* l, sensor::StereoFrontEnd& fe,
          odometry::DirectTracker& t, const fusion::FusionOptions& f)
      : options(o),
        stop(s),
        sequence(seq),
        camera(cam),
        log(l),
        front_end(fe),
        tracker(t),
        fusion_options(f),
        frame_q(o.frame_queue_capacity, policy(o)),
        disparity_q(o.frame_queue_capacity, policy(o)),
        fusion_q(o.fusion_queue_capacity, policy(o)),
        state_q(o.state_queue_capacity, policy(o)) {}

  static OverflowPolicy policy(const PipelineOptions& o) {
    return o.drops() ? OverflowPolicy::kDropOldest : OverflowPolicy::kBlock;
  }
  [[nodiscard]] bool stopping() const { return abort.load() || (stop != nullptr && stop->load()); }
  void fusion_producer_done() {
    if (fusion_producers.fetch_sub(1) == 1) fusion_q.close();
  }
  void fail(std::exception_ptr e) {
    {
      std::lock_guard lock(error_mutex);
      if (!error) error = std::move(e);
    }
    abort = true;
    frame_q.close();
    disparity_q.close();
    fusion_q.close();
    state_q.close();
  }
};

// Recorded pace: sleeps until data time `t_ns` (relative to the first pair) has come on the
// wall clock, in short steps so that a stop request is seen. False if stopping.
bool wait_for_data_time(Context& c, TimeNs t_ns, TimeNs t0_ns, Clock::time_point wall0) {
  if (c.options.pace == Pace::kRecorded) {
    const auto target = wall0 + std::chrono::nanoseconds(std::max<TimeNs>(0, t_ns - t0_ns));
    while (Clock::now() < target && !c.stopping()) {
      std::this_thread::sleep_until(std::min(target, Clock::now() + std::chrono::milliseconds(20)));
    }
  }
  return !c.stopping();
}

void folder_source_stage(Context& c, StageStats& st) {
  const io::EurocSequence& sequence = *c.sequence;
  const TimeNs t0 = sequence.stereo_timestamp(0);
  // IMU from shortly before the first pair (the static initialisation's window), not the
  // whole recording: EuRoC parts hold the IMU of the full sequence.
  const TimeNs imu_start = t0 - static_cast<TimeNs>((c.fusion_options.static_init_s + 0.1) * 1e9);
  io::ImuCsvReader imu(sequence.imu_csv());
  io::ImuSample sample;
  bool have_imu = imu.next(sample);
  const auto wall0 = Clock::now();
  for (std::size_t i = 0; i < c.frames && !c.stopping(); ++i) {
    const TimeNs t = sequence.stereo_timestamp(i);
    while (have_imu && sample.t_ns <= t) {
      if (sample.t_ns >= imu_start) {
        if (!wait_for_data_time(c, sample.t_ns, t0, wall0)) break;
        if (c.fusion_q.push(sample)) ++c.imu_samples;
      }
      have_imu = imu.next(sample);
    }
    if (!wait_for_data_time(c, t, t0, wall0)) break;
    // Decoding stands for the camera driver: the pair "arrives" once it is an image.
    const auto start = Clock::now();
    io::StereoImages images = sequence.load_stereo(i);
    const auto arrived = Clock::now();
    ++st.in;
    st.add_processing(start, arrived);
    if (c.frame_q.push(
            FrameItem{images.t_ns, arrived, std::move(images.left), std::move(images.right)})) {
      ++c.stereo_pairs;
      st.add_output(arrived, Clock::now());
    }
  }
  c.frame_q.close();
  c.fusion_producer_done();
}

// The live camera: frames as the driver delivers them (no pacing: the camera is the clock).
// Its faults end or skip as the capture loop decides; an unplugged or stalled camera ends the
// source like the end of a folder, so the stages drain and the run returns with the report.
void camera_source_stage(Context& c, StageStats& st) {
  const driver::CaptureReport report = c.camera->run(
      c.options.max_frames, [&c] { return c.stopping(); },
      [&](TimeNs t_ns, cv::Mat left, cv::Mat right, Clock::time_point start,
          Clock::time_point arrived) {
        st.add_processing(start, arrived);
        // Drop-oldest (the default for a camera) never waits here; a blocking queue makes the
        // capture wait, and the driver then drops frames itself (counted as lost).
        if (c.frame_q.push(FrameItem{t_ns, arrived, std::move(left), std::move(right)})) {
          ++c.stereo_pairs;
          st.add_output(arrived, Clock::now());
        }
      },
      c.log);
  // in: every frame the camera delivered; failed: those dropped as truncated, corrupted or
  // out of order (the capture report says which).
  st.failed = report.truncated + report.corrupted + report.out_of_order;
  st.in = report.frames + st.failed;
  c.camera_report = report;
  c.frame_q.close();
  c.fusion_producer_done();
}

void source_stage(Context& c, StageStats& st) {
  if (c.camera != nullptr)
    camera_source_stage(c, st);
  else
    folder_source_stage(c, st);
}

void depth_stage(Context& c, StageStats& st) {
  while (auto item = c.frame_q.pop()) {
    ++st.in;
    const auto start = Clock::now();
    DisparityItem out{item->t_ns, item->arrived, {}};
    c.front_end.process(item->t_ns, item->left, item->right, out.frame);
    if (out.frame.match.valid == 0) ++st.failed;
    ++c.matched_pairs;
    c.fill_sum += out.frame.match.fill_rate();
    st.add_processing(start, Clock::now());
    const auto arrived = out.arrived;
    if (c.disparity_q.push(std::move(out))) st.add_output(arrived, Clock::now());
  }
  c.disparity_q.close();
}

void tracker_stage(Context& c, StageStats& st) {
  fusion::OdometryMeasurements measurements(c.options.vo_reference, c.options.vo_covariance_scale);
  while (auto item = c.disparity_q.pop()) {
    ++st.in;
    const auto start = Clock::now();
    const odometry::TrackResult r = c.tracker.track(
        odometry::DisparityFrame{item->t_ns, item->frame.left_rect, item->frame.disparity_px});
    TrackItem out{item->t_ns, item->arrived, measurements.next(r), std::nullopt};
    if (r.ok()) {
      out.T_world_cam = r.T_world_cam;
    } else {
      ++st.failed;
    }
    st.add_processing(start, Clock::now());
    const auto arrived = out.arrived;
    if (c.fusion_q.push(std::move(out))) st.add_output(arrived, Clock::now());
  }
  c.fusion_producer_done();
}

// The fusion holds IMU samples until the tracker's result for a later frame has come, so the
// engine sees its inputs in time order however far the IMU runs ahead of the images (it
// arrives without processing delay); its own reorder window is therefore 0.
void fusion_stage(Context& c, StageStats& st) {
  fusion::FusionEngine engine(c.fusion_options);
  std::deque<io::ImuSample> held;
  auto emit = [&](const std::vector<fusion::FusedState>& states, Clock::time_point arrived) {
    for (const auto& s : states) {
      if (c.state_q.push(StateItem{s, arrived})) st.add_output(arrived, Clock::now());
    }
  };
  Clock::time_point last_arrived = Clock::now();
  while (auto input = c.fusion_q.pop()) {
    if (auto* imu = std::get_if<io::ImuSample>(&*input)) {
      held.push_back(*imu);
      continue;
    }
    const auto& item = std::get<TrackItem>(*input);
    ++st.in;
    const auto start = Clock::now();
    while (!held.empty() && held.front().t_ns <= item.t_ns) {
      engine.add_imu(held.front());
      held.pop_front();
    }
    if (item.measurement) engine.add_relative_pose(*item.measurement);
    const auto states = engine.poll(/*imu_rate=*/false);
    st.add_processing(start, Clock::now());
    last_arrived = item.arrived;
    emit(states, item.arrived);
  }
  for (const auto& s : held) engine.add_imu(s);
  emit(engine.flush(/*imu_rate=*/false), last_arrived);
  c.fusion_counters = engine.counters();
  c.state_q.close();
}

// No IMU (camera source): the fusion passes the odometry through. Its states are the tracker's
// poses of the rectified left camera (world = that camera at the tracker's first frame), with
// no covariance (sigma NaN). Failed tracks are counted and give no state.
void passthrough_fusion_stage(Context& c, StageStats& st) {
  while (auto input = c.fusion_q.pop()) {
    const auto* item = std::get_if<TrackItem>(&*input);
    if (item == nullptr) continue;  // a camera source sends no IMU samples
    ++st.in;
    const auto start = Clock::now();
    const std::optional<SE3>& T_world_cam = item->T_world_cam;
    st.add_processing(start, Clock::now());
    if (!T_world_cam) {
      ++st.failed;
      continue;
    }
    fusion::FusedState s;
    s.t_ns = item->t_ns;
    s.state.t_ns = item->t_ns;
    s.state.p_world = T_world_cam->translation();
    s.state.q_world_body = T_world_cam->unit_quaternion();
    s.sigma.setConstant(std::numeric_limits<double>::quiet_NaN());
    s.at_odometry = true;
    if (c.state_q.push(StateItem{s, item->arrived})) st.add_output(item->arrived, Clock::now());
  }
  c.state_q.close();
}

// The controller: each fused state through the control chain (ControllerStage), decided on
// a data-time clock: the state's time plus its age here (wall time since its pair arrived,
// the end-to-end latency). No state for silence_check_s: the watchdog's output is recorded
// too, at the last decision's clock plus the wall time since. The pulses are only recorded.
void controller_stage(Context& c, StageStats& st) {
  ControllerStage stage(c.options.controller, /*fused=*/c.camera == nullptr);
  const auto wait = std::chrono::duration<double>(c.options.controller.silence_check_s);
  TimeNs last_now_ns = 0;
  Clock::time_point last_wall = Clock::now();
  auto since = [](Clock::time_point a, Clock::time_point b) {
    return static_cast<TimeNs>(std::chrono::duration_cast<std::chrono::nanoseconds>(b - a).count());
  };
  while (true) {
    auto item = c.state_q.pop_for(wait);
    if (!item) {
      if (c.state_q.closed() && c.state_q.size() == 0) break;
      const auto now = Clock::now();
      if (auto r = stage.on_silence(last_now_ns + since(last_wall, now))) {
        c.controller_records.push_back(*r);
        last_now_ns = r->now_ns;
        last_wall = now;
      }
      continue;
    }
    ++st.in;
    const auto start = Clock::now();
    c.states.push_back(item->state);
    const ControllerRecord r =
        stage.on_state(item->state, item->state.t_ns + since(item->arrived, start));
    c.controller_records.push_back(r);
    if (r.input == ControllerInput::kStaleState) ++st.failed;
    last_now_ns = r.now_ns;
    last_wall = start;
    const auto end = Clock::now();
    st.add_processing(start, end);
    st.add_output(item->arrived, end);
  }
}

SE3 body_from_rectified_camera(const io::EurocSequence& sequence,
                               const Eigen::Matrix3d& R_rect_left) {
  const io::CameraFile cam0 = sequence.cam0_calibration();
  if (!cam0.T_body_sensor) {
    throw InputError(sequence.mav0() / "cam0" / "sensor.yaml", "T_BS",
                     "missing (camera-to-body extrinsics, needed by the fusion)");
  }
  // Poses are of the rectified left camera: T_body_rect = T_BS * T_cam0_rect.
  return *cam0.T_body_sensor *
         SE3(SO3::from_matrix(R_rect_left.transpose()), Eigen::Vector3d::Zero());
}

}  // namespace

PipelineReport run_pipeline(const PipelineOptions& options, const std::atomic<bool>* stop,
                            const PipelineEnvironment& environment) {
  options.validate();
  const bool camera_source = options.source == Source::kCamera;
  std::optional<io::EurocSequence> sequence;
  std::optional<CameraFrameSource> camera;
  std::optional<sensor::StereoCalibration> calibration;
  fusion::FusionOptions fusion_options = options.fusion;
  if (camera_source) {
    // The device first: a missing camera is reported before anything is built.
    camera.emplace(options.camera, options.config_file,
                   environment.camera_io ? environment.camera_io : driver::system_device_io());
    calibration = *options.camera.calibration;
  } else {
    if (!std::filesystem::exists(options.input)) {
      throw InputError(options.input.string() + ": input folder does not exist");
    }
    sequence.emplace(options.input);
    if (sequence->stereo_size() == 0) {
      throw InputError(options.input.string() +
                       ": no stereo pairs (cam0 and cam1 frames with "
                       "equal time stamps)");
    }
    if (!sequence->has_imu())
      throw InputError(options.input.string() + ": no imu0/ (the fusion needs it)");
    calibration = sensor::StereoCalibration::from_euroc(*sequence);
  }

  sensor::StereoFrontEnd front_end(*calibration, options.front_end_options());
  const RectifiedStereo& rig = front_end.rig();
  odometry::DirectTracker tracker(rig, options.tracker);
  if (!camera_source) {
    fusion_options.set_imu_noise(sequence->imu_noise());
    fusion_options.T_body_cam = body_from_rectified_camera(*sequence, front_end.R_rect_left());
    fusion_options.reorder_window_s = 0.0;  // the fusion stage orders its inputs itself
    fusion_options.validate();
  }

  Context c(options, stop, sequence ? &*sequence : nullptr, camera ? &*camera : nullptr,
            environment.log, front_end, tracker, fusion_options);
  if (sequence) {
    c.frames = options.max_frames == 0 ? sequence->stereo_size()
                                       : std::min(options.max_frames, sequence->stereo_size());
  }

  PipelineReport report;
  report.rig = rig;
  report.matcher = front_end.matcher().describe();
  report.stages.resize(5);
  const char* names[] = {"source", "depth", "tracker", "fusion", "controller"};
  for (std::size_t i = 0; i < 5; ++i) report.stages[i].name = names[i];
  using StageFn = void (*)(Context&, StageStats&);
  const StageFn fns[] = {source_stage, depth_stage, tracker_stage,
                         camera_source ? passthrough_fusion_stage : fusion_stage, controller_stage};

  const auto wall0 = Clock::now();
  std::vector<std::thread> threads;
  threads.reserve(5);
  for (std::size_t i = 0; i < 5; ++i) {
    threads.emplace_back([&c, &report, fn = fns[i], i] {
      try {
        fn(c, report.stages[i]);
      } catch (...) {
        c.fail(std::current_exception());
      }
    });
  }
  for (auto& t : threads) t.join();
  if (c.error) std::rethrow_exception(c.error);

  report.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  report.stages[1].dropped = c.frame_q.dropped();
  report.stages[2].dropped = c.disparity_q.dropped();
  report.stages[3].dropped = c.fusion_q.dropped();
  report.stages[4].dropped = c.state_q.dropped();
  report.end_to_end_ms = report.stages[3].latency_ms;
  report.states = std::move(c.states);
  report.controller = std::move(c.controller_records);
  report.controller_disarmed = camera_source && !options.controller.allow_unfused;
  report.stereo_pairs = c.stereo_pairs;
  if (c.matched_pairs > 0) {
    report.mean_disparity_fill = c.fill_sum / static_cast<double>(c.matched_pairs);
  }
  report.imu_samples = c.imu_samples;
  report.fusion_counters = c.fusion_counters;
  report.fusion_options = fusion_options;
  report.camera = c.camera_report;
  report.fusion_pass_through = camera_source;
  if (camera) {
    report.camera_info = camera->info();
    report.camera_format = camera->format();
    report.interrupted = stop != nullptr && stop->load() && c.camera_report &&
                         c.camera_report->stop == driver::CaptureStop::kInterrupted;
  } else {
    report.interrupted = stop != nullptr && stop->load() && c.stereo_pairs < c.frames;
  }
  return report;
}

}  // namespace kestrel::pipeline
