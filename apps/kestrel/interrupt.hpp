// Ctrl-C (SIGINT) and SIGTERM for the long commands: one flag, polled between frames, so that a
// command stops cleanly, writes what it has done and says so (exit status 128 + signal).
#pragma once

#include <atomic>
#include <csignal>
#include <stdexcept>
#include <string>

namespace kestrel::cli {

/// While alive, SIGINT and SIGTERM set a flag instead of ending the process; the handler does
/// nothing else (async-signal-safe). The first signal also restores the default action
/// (SA_RESETHAND), so a second Ctrl-C ends a command that does not stop. The previous handlers
/// come back when the scope ends. One scope at a time.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  /// A signal arrived since the scope began.
  [[nodiscard]] bool requested() const;
  /// The signal that arrived (SIGINT or SIGTERM), 0 if none.
  [[nodiscard]] int signal_number() const;
  /// The flag itself, for the library loops that poll one (pipeline, capture).
  [[nodiscard]] std::atomic<bool>* flag() const;

 private:
  struct sigaction previous_int_ {};
  struct sigaction previous_term_ {};
};

/// Thrown by a command after an interrupt, once it has written what it had: main prints the
/// message ("INTERRUPTED after N frames; wrote ...") and exits with exit_code().
class Interrupted : public std::runtime_error {
 public:
  Interrupted(const std::string& what, int signal_number)
      : std::runtime_error(what), signal_(signal_number) {}
  /// 130 for SIGINT, 143 for SIGTERM: the shell's convention for a process ended by a signal.
  [[nodiscard]] int exit_code() const { return 128 + (signal_ > 0 ? signal_ : SIGINT); }

 private:
  int signal_;
};

/// Throws Interrupted("INTERRUPTED " + what) with the scope's signal.
[[noreturn]] void throw_interrupted(const InterruptScope& scope, const std::string& what);

}  // namespace kestrel::cli
