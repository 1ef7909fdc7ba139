// `kestrel disparity`: block matching on one stereo pair; writes the LEFT view's disparity as
// PFM (no disparity = +inf) and, with a calibration, a 16-bit depth PNG (5000 units per metre,
// 0 = none: the TUM RGB-D convention). Raw pairs are rectified first (EuRoC folder or Kestrel
// `stereo_pair:` YAML); a `stereo:` YAML means the images are already rectified.
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>

#include "commands.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/pfm.hpp"
#include "kestrel/io/yaml_file.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"
#include "kestrel/sensor/stereo_matcher.hpp"
#include "option_checks.hpp"

namespace kestrel::cli {
namespace {
namespace fs = std::filesystem;

constexpr const char* kDisparityCommand = "disparity";

struct DisparityArgs {
  fs::path left, right, calib, options_file, out, depth_out, color_out;
  sensor::BlockMatcherOptions options;
  fs::path sgm_options_file;
  sensor::SgmOptions sgm;
  std::string matcher;  // sad | census | sgm; empty: the block matcher with --cost
  std::string cost = "sad";
  std::string prefilter = "xsobel";
  std::string backend = "cpu";
  bool no_subpixel = false;
  bool force = false;
};

/// What --calib names: a rectified rig, or a raw pair to rectify first.
struct Calibration {
  std::optional<RectifiedStereo> rig;
  std::optional<sensor::StereoRectifier> rectifier;
};

Calibration load_calibration(const fs::path& path) {
  Calibration c;
  if (path.empty()) return c;
  if (!fs::exists(path)) throw InputError(path.string() + ": no such calibration file or folder");
  if (fs::is_directory(path)) {
    const io::EurocSequence seq(path);
    c.rectifier.emplace(sensor::StereoCalibration::from_euroc(seq));
  } else {
    const YAML::Node root = io::load_yaml_file(path);
    if (root.IsMap() && root["stereo"]) {
      c.rig = io::load_rectified_stereo(path);
      return c;
    }
    if (!(root.IsMap() && root["stereo_pair"])) {
      throw InputError(path, "stereo",
                       "is missing (expected a `stereo:` map for a rectified rig "
                       "or a `stereo_pair:` map for a raw pair)");
    }
    c.rectifier.emplace(sensor::load_stereo_calibration(path));
  }
  c.rig = c.rectifier->rig();
  return c;
}

/// The 16-bit depth PNG: 5000 units per metre, 0 = none (the TUM RGB-D convention).
void write_depth(const fs::path& path, const cv::Mat& disparity, const RectifiedStereo& rig) {
  cv::Mat depth_m, depth16(disparity.size(), CV_16U);
  sensor::disparity_to_depth(disparity, rig, depth_m);
  for (int y = 0; y < depth_m.rows; ++y) {
    for (int x = 0; x < depth_m.cols; ++x) {
      const double units = std::round(5000.0 * double(depth_m.at<float>(y, x)));  // TUM: 5000 / m
      depth16.at<std::uint16_t>(y, x) = units > 65535.0 ? 0 : static_cast<std::uint16_t>(units);
    }
  }
  if (!cv::imwrite(path.string(), depth16)) throw InputError(path.string() + ": cannot write");
  std::cout << "wrote " << path.string() << " (16-bit depth, 5000 units per metre, 0 = none)\n";
}

/// What one matcher run needs besides the images: a name for the log and the match itself.
struct MatchRun {
  std::string options_line;
  int max_disparity = 0;
  std::function<sensor::MatchStats(const cv::Mat&, const cv::Mat&, cv::Mat&)> match;
  std::function<std::string()> backend_line;
};

/// Checks the outputs, reads and (with a raw calibration) rectifies the pair, matches it and
/// writes the disparity PFM and, as asked, the depth and colour PNGs.
void match_and_write(DisparityArgs& args, const Calibration& calib, const MatchRun& run) {
  if (args.out.extension() != ".pfm")
    throw InputError("--out: the disparity is written as PFM (*.pfm)");
  if (calib.rig && args.depth_out.empty()) {
    args.depth_out = args.out;
    args.depth_out.replace_extension(".depth.png");
  }
  if (!calib.rig && !args.depth_out.empty()) throw InputError("--depth needs --calib");
  // Every output before any work: none may replace an input or a file Kestrel did not write.
  io::OutputGuard(kDisparityCommand, args.force)
      .input("--left", args.left)
      .input("--right", args.right)
      .input("--calib", args.calib)
      .input("--options", args.options_file)
      .input("--sgm-options", args.sgm_options_file)
      .binary_file("--out", args.out)
      .binary_file("--depth", args.depth_out)
      .binary_file("--color", args.color_out);
  const cv::Mat left = io::read_gray_image(args.left);
  const cv::Mat right = io::read_gray_image(args.right);
  std::cerr << "kestrel disparity: " << run.options_line << "\n";
  cv::Mat l = left, r = right;
  if (calib.rectifier) {
    calib.rectifier->rectify(left, right, l, r);
    const auto& rig = *calib.rig;
    std::cerr << "kestrel disparity: rectified: f " << rig.f << " px, baseline " << rig.baseline_m
              << " m, c (" << rig.cu << ", " << rig.cv << ")\n";
  }
  std::cerr << "kestrel disparity: " << run.backend_line() << "\n";
  cv::Mat disparity;
  const auto t0 = std::chrono::steady_clock::now();
  const sensor::MatchStats stats = run.match(l, r, disparity);
  const double ms = ms_since(t0);
  io::write_pfm(args.out, disparity, true);
  std::cout << "wrote " << args.out.string() << "\n";
  if (!args.depth_out.empty()) write_depth(args.depth_out, disparity, *calib.rig);
  if (!args.color_out.empty()) {
    if (!cv::imwrite(args.color_out.string(),
                     lab::colorize_disparity(disparity, run.max_disparity))) {
      throw InputError(args.color_out.string() + ": cannot write");
    }
    std::cout << "wrote " << args.color_out.string() << "\n";
  }
  std::cout << "disparity " << disparity.cols << "x" << disparity.rows << ": " << stats.describe()
            << ", " << ms << " ms\n";
}

/// --matcher sgm: the semi-global matcher (CPU only). The disparity range comes from
/// --min/--max-disparity when given, else from --sgm-options or the defaults.
void run_sgm(DisparityArgs& args, const CLI::App& cmd) {
  for (const char* block_only : {"--block", "--cost", "--prefilter", "--uniqueness", "--texture",
                                 "--min-depth", "--max-depth", "--options"}) {
    if (cmd.count(block_only) > 0) {
      throw InputError(std::string(block_only) +
                       " is a block-matcher option; --matcher sgm "
                       "takes --sgm-options, --paths, --lr-max-diff, --speckle and --no-subpixel");
    }
  }
  if (args.backend != "cpu") throw InputError("--matcher sgm runs on the CPU only (--backend cpu)");
  sensor::SgmOptions o = args.sgm_options_file.empty()
                             ? sensor::SgmOptions{}
                             : sensor::SgmOptions::load_yaml(args.sgm_options_file);
  if (cmd.count("--max-disparity") > 0) o.max_disparity = args.options.max_disparity;
  if (cmd.count("--min-disparity") > 0) o.min_disparity = args.options.min_disparity;
  if (cmd.count("--lr-max-diff") > 0) o.lr_max_diff = args.options.lr_max_diff;
  if (cmd.count("--paths") > 0) o.paths = args.sgm.paths;
  if (cmd.count("--speckle") > 0) o.speckle_size = args.sgm.speckle_size;
  if (args.no_subpixel) o.subpixel = false;
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  const Calibration calib = load_calibration(args.calib);
  auto matcher = std::make_shared<sensor::SgmMatcher>(o);
  MatchRun run;
  run.options_line = o.describe();
  run.max_disparity = o.max_disparity;
  run.match = [matcher](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
    return matcher->match(l, r, d);
  };
  run.backend_line = [] { return std::string("cpu, SIMD ") + sensor::SgmMatcher::simd_target(); };
  match_and_write(args, calib, run);
}

void run_disparity(DisparityArgs& args, const CLI::App& cmd) {
  if (!args.options_file.empty()) {
    // The file is the base; flags given on the command line override it.
    sensor::BlockMatcherOptions o = sensor::BlockMatcherOptions::load_yaml(args.options_file);
    const auto& f = args.options;
    if (cmd.count("--max-disparity") > 0) o.max_disparity = f.max_disparity;
    if (cmd.count("--min-disparity") > 0) o.min_disparity = f.min_disparity;
    if (cmd.count("--block") > 0) o.block_size = f.block_size;
    if (cmd.count("--lr-max-diff") > 0) o.lr_max_diff = f.lr_max_diff;
    if (cmd.count("--uniqueness") > 0) o.uniqueness_ratio = f.uniqueness_ratio;
    if (cmd.count("--texture") > 0) o.texture_threshold = f.texture_threshold;
    if (cmd.count("--min-depth") > 0) o.min_depth_m = f.min_depth_m;
    if (cmd.count("--max-depth") > 0) o.max_depth_m = f.max_depth_m;
    if (cmd.count("--cost") == 0)
      args.cost = o.cost == sensor::MatchingCost::kSad ? "sad" : "census";
    if (cmd.count("--prefilter") == 0)
      args.prefilter = o.prefilter == sensor::Prefilter::kNone ? "none" : "xsobel";
    args.options = o;
  }
  if (!args.matcher.empty()) {
    sensor::StereoMatcherKind kind = sensor::StereoMatcherKind::kSad;
    try {
      sensor::parse_option(args.matcher, kind);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--matcher: ") + e.what());
    }
    if (kind == sensor::StereoMatcherKind::kSgm) {
      run_sgm(args, cmd);
      return;
    }
    if (cmd.count("--cost") > 0 && args.cost != args.matcher) {
      throw InputError("--matcher " + args.matcher + " contradicts --cost " + args.cost);
    }
    args.cost = args.matcher;
  }
  for (const char* sgm_only : {"--sgm-options", "--paths", "--speckle"}) {
    if (cmd.count(sgm_only) > 0) throw InputError(std::string(sgm_only) + " needs --matcher sgm");
  }
  if (args.cost == "census")
    args.options.cost = sensor::MatchingCost::kCensus;
  else if (args.cost != "sad")
    throw InputError("--cost: expected sad or census, got '" + args.cost + "'");
  if (args.prefilter == "none")
    args.options.prefilter = sensor::Prefilter::kNone;
  else if (args.prefilter != "xsobel")
    throw InputError("--prefilter: expected xsobel or none");
  if (args.no_subpixel) args.options.subpixel = false;
  gpu::Backend backend = gpu::Backend::kCpu;
  try {
    backend = gpu::backend_from_string(args.backend);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--backend: ") + e.what());
  }
  try {
    args.options.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  const Calibration calib = load_calibration(args.calib);
  auto matcher = std::make_shared<gpu::StereoMatcher>(args.options, calib.rig, backend);
  MatchRun run;
  run.options_line = args.options.describe();
  run.max_disparity = args.options.max_disparity;
  run.match = [matcher](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
    return matcher->match(l, r, d);
  };
  run.backend_line = [matcher] {
    return std::string("backend ") + std::string(gpu::to_string(matcher->backend()));
  };
  match_and_write(args, calib, run);
}

}  // namespace

void add_disparity_command(CLI::App& app) {
  auto args = std::make_shared<DisparityArgs>();
  CLI::App* cmd =
      app.add_subcommand("disparity",
                         "Stereo matching on one pair (block matching, or semi-global with "
                         "--matcher sgm): the left view's disparity as PFM (+inf = none) and, with "
                         "--calib, a 16-bit depth PNG.");
  auto& o = args->options;
  cmd->add_option("--left", args->left, "left image")->required();
  cmd->add_option("--right", args->right, "right image")->required();
  cmd->add_option("--calib", args->calib,
                  "calibration: Kestrel `stereo:` YAML (already rectified), Kestrel "
                  "`stereo_pair:` YAML or an EuRoC folder (raw pair: rectified first)");
  cmd->add_option("--max-disparity", o.max_disparity,
                  "disparities searched: min <= d < max (OpenCV numDisparities for min 0)")
      ->capture_default_str()
      ->check(whole_in(1, 1024, "a whole number of pixels from 1 to 1024"));
  cmd->add_option("--min-disparity", o.min_disparity, "smallest disparity searched")
      ->capture_default_str()
      ->check(whole_in(0, 1023, "a whole number of pixels from 0 to 1023"));
  cmd->add_option("--block", o.block_size, "matching window side (odd)")
      ->capture_default_str()
      ->check(whole_in(3, 51, "an odd whole number of pixels from 3 to 51", true));
  cmd->add_option("--matcher", args->matcher,
                  "sad (fast block matching, the default), census (block matching on census "
                  "costs) or sgm (semi-global matching: denser, slower; docs/stereo.md)");
  cmd->add_option("--cost", args->cost, "block matcher cost: sad or census")->capture_default_str();
  cmd->add_option("--prefilter", args->prefilter, "SAD prefilter: xsobel or none")
      ->capture_default_str();
  cmd->add_option("--lr-max-diff", o.lr_max_diff, "left-right check tolerance [px], -1 = off")
      ->capture_default_str()
      ->check(whole_in(-1, 1024, "a whole number of pixels from 0 to 1024, or -1 for off"));
  cmd->add_option("--uniqueness", o.uniqueness_ratio, "uniqueness margin [%], 0 = off")
      ->capture_default_str()
      ->check(whole_in(0, 100, "a whole percentage from 0 (off) to 100"));
  cmd->add_option("--texture", o.texture_threshold, "least mean |gradient| in the window, 0 = off")
      ->capture_default_str()
      ->check(number_in(0.0, 255.0, "grey levels per pixel in [0, 255] (0: off)"));
  cmd->add_option("--min-depth", o.min_depth_m, "drop nearer points [m] (needs --calib)")
      ->check(number_in(0.0, 10000.0, "a depth in [0, 10000] m"));
  cmd->add_option("--max-depth", o.max_depth_m, "drop farther points [m] (needs --calib)")
      ->check(number_in(0.0, 10000.0, "a depth in (0, 10000] m", true));
  cmd->add_flag("--no-subpixel", args->no_subpixel, "integer disparities");
  cmd->add_option("--backend", args->backend,
                  "block matcher: cpu, cuda (an error without a CUDA device) or auto (cuda "
                  "when there is one); see docs/gpu.md")
      ->capture_default_str();
  cmd->add_option("--options", args->options_file,
                  "block matcher options YAML (flags given override it)");
  cmd->add_option("--sgm-options", args->sgm_options_file,
                  "semi-global matcher options YAML (--matcher sgm; flags given override it)");
  cmd->add_option("--paths", args->sgm.paths, "--matcher sgm: directions summed, 4 or 8")
      ->capture_default_str()
      ->check(whole_of({4, 8}, "4 or 8 directions"));
  cmd->add_option("--speckle", args->sgm.speckle_size,
                  "--matcher sgm: remove regions of at most this many pixels, 0 = off")
      ->capture_default_str()
      ->check(whole_in(0, 100000, "a whole number of pixels from 0 (off) to 100000"));
  cmd->add_option("--out", args->out, "disparity PFM")->required();
  cmd->add_option("--depth", args->depth_out,
                  "depth PNG (default with --calib: OUT with .depth.png)");
  cmd->add_option("--color", args->color_out, "false-colour PNG of the disparity");
  cmd->add_flag("--force", args->force,
                "overwrite existing output files (images carry no mark of what wrote them)");
  cmd->callback([args, cmd] { run_disparity(*args, *cmd); });
}

}  // namespace kestrel::cli
