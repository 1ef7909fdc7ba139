// placeholder: being written
#include "commands.hpp"
namespace kestrel::cli {
void add_render_command(CLI::App& app) { app.add_subcommand("render", "(not yet implemented)"); }
}  // namespace kestrel::cli
