// `kestrel lab`: experiments and studies that run the on-board code on rendered or recorded
// data (src/lab). Kept apart from the user's commands so that `kestrel --help` shows what a
// user runs first.
#include <memory>
#include <string>

#include "commands.hpp"
#include "kestrel/core/error.hpp"

namespace kestrel::cli {

namespace {

// The lab commands were top-level before `kestrel lab` existed; a script that still calls them
// gets an error that names the new command instead of "unknown subcommand".
void add_moved_command(CLI::App& app, const std::string& name) {
  CLI::App* cmd = app.add_subcommand(name, "moved to `kestrel lab " + name + "`");
  cmd->group("");  // hidden from --help
  cmd->allow_extras();
  cmd->callback([name] {
    throw InputError("`kestrel " + name + "` is now `kestrel lab " + name + "` (same options)");
  });
}

}  // namespace

void add_lab_command(CLI::App& app) {
  CLI::App* lab = app.add_subcommand(
      "lab",
      "Experiments and studies: the thesis' stereo experiment, the fusion's EuRoC and "
      "Monte-Carlo studies (`kestrel lab --help`).");
  lab->group("Lab");
  lab->require_subcommand(1);
  add_fuse_eval_command(*lab);
  add_stereo_experiment_command(*lab);
  for (const char* name : {"fuse-eval", "stereo-experiment"}) add_moved_command(app, name);
}

}  // namespace kestrel::cli
