// placeholder: being written
#include "commands.hpp"
namespace kestrel::cli {
void add_evaluate_command(CLI::App& app) { app.add_subcommand("evaluate", "(not yet implemented)"); }
}  // namespace kestrel::cli
