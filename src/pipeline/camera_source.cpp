// The camera source: the driver's capture loop, its frames demosaiced to grey for the depth stage.
#include "camera_source.hpp"

#include <stdexcept>
#include <utility>

#include "kestrel/core/error.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

}  // namespace

CameraFrameSource::CameraFrameSource(const CameraSourceOptions& options, const fs::path& config,
                                     std::shared_ptr<driver::DeviceIo> io)
    : options_(options), config_(config), decoder_(options.decoder) {
  try {
    camera_ = std::make_unique<driver::V4l2Camera>(options.device, std::move(io));
  } catch (const driver::DeviceError& e) {
    throw io::field_error(config, "camera.device", e.what());  // e.what() starts with the path
  }
  try {
    format_ = camera_->configure(options.camera);
  } catch (const driver::DeviceError& e) {
    throw io::field_error(config, "camera", e.what());  // wrong pixel format or size, busy, ...
  }
}

driver::CaptureReport CameraFrameSource::run(std::size_t max_frames,
                                             const std::function<bool()>& stop,
                                             const PairSink& sink, std::ostream* log) {
  driver::CaptureLimits limits;
  limits.frames = max_frames;
  limits.timeout_s = options_.timeout_s;
  driver::CaptureHooks hooks;
  hooks.log = log;
  hooks.stop_requested = stop;
  auto to_pair = [&](TimeNs t_ns, const driver::StereoMosaic& mosaic, std::span<const std::uint8_t>,
                     std::size_t) {
    // Demosaicing is this stage's work: the pair "arrives" once it is a grey image, as a
    // folder's pair does once decoded. Fresh buffers: they travel down the queues.
    const auto start = Clock::now();
    cv::Mat left, right;
    decoder_.convert(mosaic.left, driver::ViewKind::kGray, left);
    decoder_.convert(mosaic.right, driver::ViewKind::kGray, right);
    sink(t_ns, std::move(left), std::move(right), start, Clock::now());
  };
  try {
    return driver::capture_stereo(*camera_, format_, decoder_, limits, to_pair, hooks);
  } catch (const driver::DeviceError& e) {
    throw io::field_error(config_, "camera.device", e.what());  // e.g. no buffers, STREAMON
  }
}

}  // namespace kestrel::pipeline
