// `kestrel capture`: lists the V4L2 video devices and their formats, records a UVC stereo camera
// that packs two Bayer sensors into YUYV frames to an EuRoC folder, or decodes one raw packed
// frame offline (to find the byte order and Bayer phase of a new camera). docs/driver.md.
#include <fstream>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/driver/stereo_capture.hpp"
#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/driver/stereo_recorder.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "kestrel/io/output_guard.hpp"
#include "option_checks.hpp"
#include "progress.hpp"

namespace kestrel::cli {

namespace {

namespace fs = std::filesystem;
using driver::StereoRecorder;

struct CaptureArgs {
  bool list = false;
  std::string device = "/dev/video0";
  bool device_given = false;
  std::string out;
  std::size_t frames = 0;
  double duration_s = 0.0;
  double timeout_s = 2.0;
  double rate_hz = 0.0;
  std::string pixel_format = "YUYV";
  int buffers = 4;
  int width = 752;
  int height = 480;
  int left_byte = 0;
  std::string bayer = "GRBG";
  std::string demosaic = "bilinear";
  std::string decoder_options;
  std::string images = "gray";
  bool raw = false;
  std::string decode_file;
  bool force = false;
};

driver::StereoDecoderOptions decoder_options(const CaptureArgs& a) {
  if (!a.decoder_options.empty()) return driver::StereoDecoderOptions::load_yaml(a.decoder_options);
  driver::StereoDecoderOptions o;
  o.width = a.width;
  o.height = a.height;
  o.left_byte = a.left_byte;
  const auto phase = driver::parse_bayer_phase(a.bayer);
  if (!phase)
    throw InputError("capture: --bayer must be GRBG, RGGB, BGGR or GBRG, got '" + a.bayer + "'");
  o.phase = *phase;
  const auto method = driver::parse_demosaic_method(a.demosaic);
  if (!method) {
    throw InputError("capture: --demosaic must be bilinear or edge-aware, got '" + a.demosaic +
                     "'");
  }
  o.demosaic = *method;
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("capture: ") + e.what());
  }
  return o;
}

driver::ViewKind view_kind(const CaptureArgs& a) {
  const auto kind = driver::parse_view_kind(a.images);
  if (!kind)
    throw InputError("capture: --images must be gray, color or mosaic, got '" + a.images + "'");
  return *kind;
}

void print_device(std::ostream& os, const std::string& path) {
  try {
    const driver::V4l2Camera camera(path);
    os << camera.info().describe() << "\n";
    for (const auto& f : camera.formats()) os << "    " << f.describe() << "\n";
  } catch (const driver::DeviceError& e) {
    os << e.what() << "\n";
  }
}

void list_devices(const CaptureArgs& a) {
  if (a.device_given) {
    print_device(std::cout, a.device);
    return;
  }
  const auto nodes = driver::list_video_devices();
  if (nodes.empty()) {
    std::cout << "no video devices: /dev has no video* nodes (is the camera plugged in, and "
                 "its driver - uvcvideo for UVC cameras - loaded?)\n";
    return;
  }
  for (const auto& node : nodes) print_device(std::cout, node.string());
}

/// Decodes one packed frame from a file (e.g. raw/<t_ns>.bin of `capture --raw`).
void decode_file(const CaptureArgs& a) {
  if (a.out.empty()) throw InputError("capture: --decode-file needs --out");
  if (std::filesystem::is_directory(a.decode_file)) {
    throw InputError(a.decode_file +
                     ": is a folder; --decode-file takes one raw frame file "
                     "(raw/<t_ns>.bin of `capture --raw`)");
  }
  const driver::StereoFrameDecoder decoder(decoder_options(a));
  const driver::ViewKind kind = view_kind(a);
  std::ifstream in(a.decode_file, std::ios::binary);
  if (!in) throw InputError(a.decode_file + ": cannot open");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  driver::StereoMosaic mosaic;
  const driver::FrameHealth health = decoder.split(bytes, 0, mosaic);
  if (!health.ok()) {
    throw InputError(a.decode_file + ": " + health.describe() + " for one " +
                     std::to_string(decoder.options().width) + "x" +
                     std::to_string(decoder.options().height) +
                     " packed frame (wrong --width/--height?)");
  }
  std::cout << "kestrel capture --decode-file " << a.decode_file << "\n"
            << "  decoder: " << decoder.options().describe() << "\n"
            << "  images:  " << driver::view_kind_name(kind) << "\n";
  if (bytes.size() > health.expected_bytes) {
    std::cout << "  note:    the file holds " << bytes.size() << " bytes; decoded its first "
              << health.expected_bytes << "\n";
  }
  io::OutputGuard(StereoRecorder::kCommand, a.force)
      .input("--decode-file", a.decode_file)
      .input("--decoder-options", a.decoder_options)
      .folder("--out", a.out);
  cv::Mat view;
  for (const auto& [m, name] :
       {std::pair{&mosaic.left, "left.png"}, {&mosaic.right, "right.png"}}) {
    decoder.convert(*m, kind, view);
    const fs::path file = fs::path(a.out) / name;
    if (!cv::imwrite(file.string(), view)) throw InputError(file.string() + ": cannot write image");
  }
  std::cout << "wrote left.png and right.png to " << a.out << "\n";
}

void record(const CaptureArgs& a) {
  if (a.out.empty()) {
    throw InputError(
        "capture: --out is required (or --list to see the devices, --decode-file "
        "to decode a raw frame)");
  }
  const driver::StereoFrameDecoder decoder(decoder_options(a));
  driver::RecorderOptions ro;
  ro.images = view_kind(a);
  ro.raw = a.raw;
  driver::CaptureLimits limits;
  limits.frames = a.frames;
  limits.duration_s = a.duration_s;
  limits.timeout_s = a.timeout_s;
  driver::CameraOptions co;
  co.pixel_format = a.pixel_format;
  co.width = decoder.options().width;
  co.height = decoder.options().height;
  co.rate_hz = a.rate_hz;
  co.buffers = a.buffers;
  try {
    limits.validate();
    co.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("capture: ") + e.what());
  }

  // The device first: a missing camera must not leave an empty output folder behind.
  driver::V4l2Camera camera(a.device);
  const driver::StreamFormat format = camera.configure(co);

  std::ostringstream log;
  log << "kestrel capture\n"
      << "  device:   " << camera.info().describe() << "\n"
      << "  asked:    " << co.describe() << "\n"
      << "  format:   " << format.describe() << "\n"
      << "  decoder:  " << decoder.options().describe() << "\n"
      << "  recorder: " << ro.describe() << "\n"
      << "  until:    ";
  if (a.frames > 0) log << a.frames << " frames ";
  if (a.duration_s > 0.0) log << a.duration_s << " s ";
  if (a.frames == 0 && a.duration_s == 0.0) log << "Ctrl-C ";
  log << "(or no frame for " << a.timeout_s << " s)\n"
      << "  output:   " << a.out << "\n";
  std::cout << log.str() << std::flush;

  // The folder is claimed here (the recorder claims it again, as its own).
  io::OutputGuard(StereoRecorder::kCommand, a.force)
      .input("--decoder-options", a.decoder_options)
      .folder("--out", a.out);
  StereoRecorder recorder(a.out, decoder.options(), ro, a.force);
  const fs::path info = fs::path(a.out) / "capture.txt";
  io::check_can_write_file(info, StereoRecorder::kCommand, true);
  std::ofstream info_out(info);
  info_out << io::provenance_line(StereoRecorder::kCommand) << "\n" << log.str() << std::flush;

  // Ctrl-C ends a recording cleanly (files finished).
  const InterruptScope interrupt;
  ProgressBar progress("capture", a.frames);
  driver::CaptureHooks hooks;
  hooks.log = &std::cerr;
  hooks.interrupt = interrupt.flag();
  hooks.on_frame = [&](const driver::CaptureReport& r) { progress.update(r.frames); };
  const driver::CaptureReport report = driver::capture_stereo(
      camera, format, decoder, limits,
      [&](TimeNs t_ns, const driver::StereoMosaic& m, std::span<const std::uint8_t> packed,
          std::size_t bytes_per_line) { recorder.write(t_ns, m, packed, bytes_per_line); },
      hooks);
  recorder.finish();
  progress.finish();
  info_out << "  result:   " << report.describe() << "\n";
  if (!info_out) throw InputError(info.string() + ": cannot write");
  std::cout << "captured " << report.describe() << "\n";
  if (!report.ended_as_asked()) {
    throw InputError("capture: " + std::string(driver::capture_stop_name(report.stop)) + " after " +
                     std::to_string(report.frames) + " frames: " + report.stop_message +
                     "; the frames recorded so far are in " + a.out);
  }
  // Without --frames or --duration, Ctrl-C is the asked end; with them it cut the run short.
  if (interrupt.requested() && (a.frames > 0 || a.duration_s > 0.0)) {
    throw_interrupted(interrupt, "after " + std::to_string(report.frames) +
                                     " stereo frames; wrote them to " + a.out);
  }
  std::cout << "wrote " << report.frames << " stereo frames to " << a.out << "\n";
}

void run_capture(const CaptureArgs& a) {
  if (a.list) {
    list_devices(a);
  } else if (!a.decode_file.empty()) {
    decode_file(a);
  } else {
    record(a);
  }
}

}  // namespace

void add_capture_command(CLI::App& app) {
  auto args = std::make_shared<CaptureArgs>();
  CLI::App* cmd = app.add_subcommand(
      "capture",
      "Record a UVC stereo camera whose two Bayer sensors arrive packed in YUYV frames (e.g. "
      "LI-USB30-V024STEREO) to an EuRoC folder; list the video devices; decode a raw frame");
  auto* list = cmd->add_flag("--list", args->list,
                             "List the video devices and their formats (only --device's if given)");
  auto* device =
      cmd->add_option("--device", args->device, "V4L2 device node")->capture_default_str();
  cmd->add_option("--out", args->out,
                  "Output folder (created; refused if it holds other files unless --force)");
  auto* frames = cmd->add_option("--frames", args->frames,
                                 "Stop after this many stereo frames (default: Ctrl-C)")
                     ->check(whole_in(1, 100000000, "a whole number of frames, 1 to 100000000"));
  auto* duration = cmd->add_option("--duration", args->duration_s,
                                   "Stop after this many seconds of frames (camera clock)")
                       ->check(number_in(0.0, 86400.0, "a duration in (0, 86400] s", true));
  frames->excludes(duration);
  cmd->add_option("--timeout", args->timeout_s,
                  "End the capture when no frame comes for this many seconds")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a timeout in (0, 3600] s", true));
  cmd->add_option("--rate", args->rate_hz, "Frame rate to ask for in Hz (default: the device's)")
      ->check(number_in(0.0, 1000.0, "a rate in (0, 1000] Hz", true));
  cmd->add_option("--pixel-format", args->pixel_format,
                  "Fourcc the packed frames are labelled with (YUYV; Y8I on some cameras)")
      ->capture_default_str();
  cmd->add_option("--buffers", args->buffers, "Memory-mapped buffers (2..32)")
      ->capture_default_str()
      ->check(whole_in(2, 32, "a whole number of buffers from 2 to 32"));
  auto* width = cmd->add_option("--width", args->width, "Width of each view = of the YUYV frame")
                    ->capture_default_str()
                    ->check(whole_in(2, 8192, "a whole number of pixels from 2 to 8192"));
  auto* height = cmd->add_option("--height", args->height, "Height of each view")
                     ->capture_default_str()
                     ->check(whole_in(2, 8192, "a whole number of pixels from 2 to 8192"));
  auto* left_byte = cmd->add_option("--left-byte", args->left_byte,
                                    "Byte (0 or 1) of each 16-bit word holding the left sensor")
                        ->capture_default_str()
                        ->check(whole_in(0, 1, "0 or 1"));
  auto* bayer = cmd->add_option("--bayer", args->bayer,
                                "Bayer phase of the sensors: GRBG, RGGB, BGGR or GBRG")
                    ->capture_default_str();
  auto* demosaic = cmd->add_option("--demosaic", args->demosaic, "bilinear or edge-aware")
                       ->capture_default_str();
  auto* yaml = cmd->add_option("--decoder-options", args->decoder_options,
                               "YAML file of decoder options (width, height, left_byte, bayer, "
                               "demosaic) instead of the flags");
  for (auto* flag : {width, height, left_byte, bayer, demosaic}) yaml->excludes(flag);
  cmd->add_option("--images", args->images,
                  "What the PNGs hold: gray, color or mosaic (raw Bayer samples)")
      ->capture_default_str();
  cmd->add_flag("--raw", args->raw,
                "Also keep each packed frame as raw/<t_ns>.bin (for --decode-file)");
  auto* decode = cmd->add_option("--decode-file", args->decode_file,
                                 "Decode one packed frame from this file into --out "
                                 "(left.png, right.png) instead of capturing")
                     ->check(CLI::ExistingFile);
  decode->excludes(list);
  cmd->add_flag("--force", args->force, "Write into a folder that holds other files");
  cmd->callback([args, device] {
    args->device_given = device->count() > 0;
    run_capture(*args);
  });
}

}  // namespace kestrel::cli
