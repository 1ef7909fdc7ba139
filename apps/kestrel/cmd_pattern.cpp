// `kestrel pattern`: the projector's random-line pattern (thesis 2.3) as a PNG.
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "commands.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "option_checks.hpp"

namespace kestrel::cli {
namespace {

constexpr const char* kPatternCommand = "pattern";

struct PatternArgs {
  sensor::PatternOptions options;
  std::string colors = "primaries";
  std::uint64_t seed = 1;
  std::filesystem::path out;
  bool force = false;
};

void run_pattern(PatternArgs& args) {
  args.options.colors = sensor::parse_pattern_colors(args.colors);
  try {
    args.options.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  if (args.out.extension() != ".png")
    throw InputError("--out: the pattern is written as PNG (*.png)");
  io::OutputGuard(kPatternCommand, args.force).binary_file("--out", args.out);
  std::cerr << "kestrel pattern: " << args.options.describe() << ", seed " << args.seed << "\n";
  const cv::Mat pattern = sensor::generate_pattern(args.options, args.seed);
  if (!cv::imwrite(args.out.string(), pattern))
    throw InputError(args.out.string() + ": cannot write");
  std::cout << "wrote " << args.out.string() << "\n";
}

}  // namespace

void add_pattern_command(CLI::App& app) {
  auto args = std::make_shared<PatternArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pattern",
      "Generate the projector pattern: random lines of random colour, position and "
      "orientation (thesis 2.3); the same seed gives the same image.");
  auto& o = args->options;
  cmd->add_option("--lines", o.lines, "number of lines")
      ->capture_default_str()
      ->check(whole_in(1, 100000, "a whole number of lines, 1 to 100000"));
  cmd->add_option("--width", o.width, "image width [px] (projector resolution)")
      ->capture_default_str()
      ->check(whole_in(1, 8192, "a whole number of pixels from 1 to 8192"));
  cmd->add_option("--height", o.height, "image height [px]")
      ->capture_default_str()
      ->check(whole_in(1, 8192, "a whole number of pixels from 1 to 8192"));
  cmd->add_flag("--segments{false}", o.full_lines,
                "draw segments of --min-length..--max-length instead of lines across the image");
  cmd->add_option("--min-length", o.min_length_px, "shortest segment [px] (--segments)")
      ->check(number_in(1.0, 100000.0, "a length in [1, 100000] px"))
      ->capture_default_str();
  cmd->add_option("--max-length", o.max_length_px, "longest segment [px] (--segments)")
      ->check(number_in(1.0, 100000.0, "a length in [1, 100000] px"))
      ->capture_default_str();
  cmd->add_option("--min-thickness", o.min_thickness_px, "thinnest line [px]")
      ->capture_default_str()
      ->check(whole_in(1, 64, "a whole number of pixels from 1 to 64"));
  cmd->add_option("--max-thickness", o.max_thickness_px, "thickest line [px]")
      ->capture_default_str()
      ->check(whole_in(1, 64, "a whole number of pixels from 1 to 64"));
  cmd->add_option("--colors", args->colors, "colour set: primaries, random or white")
      ->capture_default_str();
  cmd->add_flag("--aliased{false}", o.antialiased, "draw hard (not antialiased) lines");
  cmd->add_option("--seed", args->seed, "random seed")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  cmd->add_option("--out", args->out, "output PNG")->required();
  cmd->add_flag("--force", args->force,
                "overwrite an existing file (images carry no mark of what wrote them)");
  cmd->callback([args] { run_pattern(*args); });
}

}  // namespace kestrel::cli
