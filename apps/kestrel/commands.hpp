// The subcommands of `kestrel`: the user's commands (cmd_<name>.cpp) and, under `kestrel lab`,
// the experiments and studies (lab_<name>.cpp). Each file registers one.
#pragma once

#include <CLI/CLI.hpp>

namespace kestrel::cli {

/// Every command of `kestrel` on `app`: the user's, in the order of the pipeline, in the
/// "Commands" group; then `lab`.
void add_commands(CLI::App& app);

void add_evaluate_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_odometry_command(CLI::App& app);
void add_fuse_command(CLI::App& app);
void add_pattern_command(CLI::App& app);
void add_disparity_command(CLI::App& app);
void add_fly_command(CLI::App& app);
void add_capture_command(CLI::App& app);
void add_run_command(CLI::App& app);

/// `kestrel lab`: the group of lab commands below, and hidden stand-ins for their former
/// top-level names that say where they went.
void add_lab_command(CLI::App& app);
void add_fuse_eval_command(CLI::App& lab);
void add_stereo_experiment_command(CLI::App& lab);

}  // namespace kestrel::cli
