#include "stop_signal.h"

namespace ef::app {

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;
volatile std::sig_atomic_t g_stop_count = 0;

extern "C" void on_stop_signal(int sig) {
  g_stop_signal = sig;
  g_stop_count = g_stop_count + 1;
}
}  // namespace

StopSignalScope::StopSignalScope() {
  g_stop_signal = 0;
  g_stop_count = 0;
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;  // file reads and writes in progress complete normally
  sigaction(SIGINT, &sa, &old_int_);
  sigaction(SIGTERM, &sa, &old_term_);
}

StopSignalScope::~StopSignalScope() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
}

bool StopSignalScope::stop_requested() const { return g_stop_signal != 0; }
int StopSignalScope::signal_number() const { return static_cast<int>(g_stop_signal); }
int StopSignalScope::signals() const { return static_cast<int>(g_stop_count); }

}  // namespace ef::app
