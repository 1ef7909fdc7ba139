// The command tree of `kestrel`, shared by main() and the tests that walk it.
#include "commands.hpp"

namespace kestrel::cli {

void add_commands(CLI::App& app) {
  // The user's commands, in the order of the pipeline; then the lab's group.
  add_odometry_command(app);
  add_disparity_command(app);
  add_fuse_command(app);
  add_evaluate_command(app);
  add_run_command(app);
  add_capture_command(app);
  add_fly_command(app);
  add_render_command(app);
  add_pattern_command(app);
  for (CLI::App* cmd : app.get_subcommands([](CLI::App*) { return true; })) {
    cmd->group("Commands");
  }
  add_lab_command(app);
}

}  // namespace kestrel::cli
