// `kestrel evaluate`: ATE, RPE and per-axis errors of an estimated trajectory against ground
// truth, as the TUM RGB-D benchmark scripts compute them; optional CSVs and figures.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "option_checks.hpp"

namespace kestrel::cli {
namespace {

constexpr const char* kEvaluateCommand = "evaluate";

struct EvaluateArgs {
  std::filesystem::path gt_path;
  std::filesystem::path est_path;
  std::filesystem::path plot_dir;  // empty: no files
  eval::EvaluationOptions options;
  double offset_s = 0.0;  // added to the estimate's stamps (the TUM scripts' --offset)
  bool force = false;
};

void require_positive(double value, const char* flag) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw InputError(std::string(flag) + ": must be a positive number of seconds, got " +
                     io::format_double(value));
  }
}

Trajectory load(const std::filesystem::path& path, const char* role) {
  const io::TrajectoryFormat format = io::detect_trajectory_format(path);
  Trajectory trajectory = io::read_trajectory(path);
  if (trajectory.empty()) throw InputError(path.string() + ": holds no poses");
  std::cerr << "kestrel evaluate: " << role << " " << path.string() << ": " << trajectory.size()
            << " poses (" << io::format_name(format) << ")\n";
  return trajectory;
}

void run_evaluate(const EvaluateArgs& args) {
  std::cerr << "kestrel evaluate: gt=" << args.gt_path.string() << " est=" << args.est_path.string()
            << " plot=" << (args.plot_dir.empty() ? "(none)" : args.plot_dir.string())
            << " force=" << (args.force ? "true" : "false") << " " << args.options.describe()
            << " offset_s=" << io::format_double(args.offset_s) << "\n";
  require_positive(args.options.max_diff_s, "--max-diff");
  require_positive(args.options.rpe_delta_s, "--delta");
  if (!std::isfinite(args.offset_s) || std::fabs(args.offset_s) > 1e6) {
    throw InputError("--offset: must be a finite number of seconds (|offset| <= 1e6), got " +
                     io::format_double(args.offset_s));
  }
  // Claim the output folder before the work, so that a refusal comes at once.
  io::OutputGuard(kEvaluateCommand, args.force)
      .input("--gt", args.gt_path)
      .input("--est", args.est_path)
      .folder("--plot", args.plot_dir);

  const Trajectory gt = load(args.gt_path, "ground truth");
  Trajectory est = load(args.est_path, "estimate");
  // A known clock offset of the estimate's sensor (e.g. camera vs motion capture): shift its
  // stamps before the association, as the TUM scripts' --offset does to their second file.
  const auto offset_ns = static_cast<TimeNs>(std::llround(args.offset_s * 1e9));
  for (auto& pose : est) pose.t_ns += offset_ns;
  eval::Evaluation evaluation;
  try {
    evaluation = eval::evaluate(gt, est, args.options);
  } catch (const InputError& e) {
    // The metrics do not know the file names; say which files did not fit together.
    throw InputError("evaluating " + args.est_path.string() + " against " + args.gt_path.string() +
                     ": " + e.what());
  }

  std::cout << eval::format_report(evaluation);
  if (!args.plot_dir.empty()) {
    for (const auto& path : eval::write_evaluation_files(args.plot_dir, gt, est, evaluation,
                                                         kEvaluateCommand, args.force)) {
      std::cout << "wrote " << path.string() << "\n";
    }
  }
  // The last line is for scripts: keep its format stable.
  std::cout << eval::format_summary_line(evaluation) << std::endl;
}

}  // namespace

void add_evaluate_command(CLI::App& app) {
  auto args = std::make_shared<EvaluateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate",
      "Evaluate an estimated trajectory against ground truth (TUM RGB-D benchmark ATE and "
      "RPE, per-axis errors). Files: TUM or EuRoC CSV, detected from the content.");
  cmd->add_option("--gt", args->gt_path, "ground-truth trajectory file")->required();
  cmd->add_option("--est", args->est_path, "estimated trajectory file")->required();
  cmd->add_option("--plot", args->plot_dir,
                  "folder for the per-axis and RPE CSVs, the aligned estimate and PNG figures");
  cmd->add_option("--max-diff", args->options.max_diff_s,
                  "ATE association: largest time difference of a gt/est pair [s]")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a time difference in (0, 3600] s", true));
  cmd->add_option("--delta", args->options.rpe_delta_s, "RPE window length [s]")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a window length in (0, 3600] s", true));
  cmd->add_option("--offset", args->offset_s,
                  "time offset added to the estimate's stamps before the association [s] "
                  "(the TUM scripts' --offset)")
      ->capture_default_str()
      ->check(number_in(-1e6, 1e6, "an offset in [-1000000, 1000000] s"));
  cmd->add_flag("--force", args->force,
                "write into a folder or over files not written by "
                "`kestrel evaluate`");
  cmd->callback([args] { run_evaluate(*args); });
}

}  // namespace kestrel::cli
