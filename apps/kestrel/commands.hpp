// The subcommands of `kestrel`; each file cmd_<name>.cpp registers one.
#pragma once

#include <CLI/CLI.hpp>

namespace kestrel::cli {

void add_evaluate_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_odometry_command(CLI::App& app);
void add_fuse_command(CLI::App& app);
void add_fuse_eval_command(CLI::App& app);
void add_pattern_command(CLI::App& app);
void add_disparity_command(CLI::App& app);
void add_stereo_experiment_command(CLI::App& app);
void add_fly_command(CLI::App& app);
void add_capture_command(CLI::App& app);
void add_run_command(CLI::App& app);

}  // namespace kestrel::cli
