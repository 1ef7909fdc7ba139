// kestrel: visual odometry, active stereo, VO+IMU fusion and control for MAVs.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "commands.hpp"
#include "interrupt.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "kestrel: direct visual odometry, active stereo, VO+IMU fusion and control for MAVs"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "kestrel 0.1.0");
  kestrel::cli::add_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const kestrel::cli::Interrupted& e) {
    // The command stopped on Ctrl-C / SIGTERM after writing what it had; it says what.
    std::cerr << "kestrel: " << e.what() << "\n";
    return e.exit_code();
  } catch (const std::exception& e) {
    // Subcommand callbacks run inside parse(); any failure there is reported here once.
    std::cerr << "kestrel: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
