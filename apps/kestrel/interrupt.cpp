// The one SIGINT/SIGTERM handler of the `kestrel` commands (interrupt.hpp).
#include "interrupt.hpp"

#include <cassert>

namespace kestrel::cli {
namespace {

// What a signal handler may touch: a lock-free atomic and a sig_atomic_t.
std::atomic<bool> g_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);
volatile std::sig_atomic_t g_signal = 0;
std::atomic<int> g_scopes{0};

extern "C" void on_interrupt_signal(int signal_number) {
  g_signal = signal_number;
  g_requested.store(true);
}

void install(int signal_number, struct sigaction* previous) {
  struct sigaction action {};
  action.sa_handler = on_interrupt_signal;
  sigemptyset(&action.sa_mask);
  // Restart interrupted system calls (file writes) and let a second signal end the process.
  action.sa_flags = SA_RESTART | SA_RESETHAND;
  sigaction(signal_number, &action, previous);
}

}  // namespace

InterruptScope::InterruptScope() {
  [[maybe_unused]] const int before = g_scopes.fetch_add(1);
  assert(before == 0 && "one InterruptScope at a time");
  g_signal = 0;
  g_requested.store(false);
  install(SIGINT, &previous_int_);
  install(SIGTERM, &previous_term_);
}

InterruptScope::~InterruptScope() {
  sigaction(SIGINT, &previous_int_, nullptr);
  sigaction(SIGTERM, &previous_term_, nullptr);
  g_scopes.fetch_sub(1);
}

bool InterruptScope::requested() const { return g_requested.load(); }

int InterruptScope::signal_number() const { return g_requested.load() ? int{g_signal} : 0; }

std::atomic<bool>* InterruptScope::flag() const { return &g_requested; }

void throw_interrupted(const InterruptScope& scope, const std::string& what) {
  throw Interrupted("INTERRUPTED " + what, scope.signal_number());
}

}  // namespace kestrel::cli
