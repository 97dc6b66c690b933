#include "Examples/coloc/stop_signals.hpp"

#include <pthread.h>

#include <ctime>

namespace coloc::cli {

sigset_t stop_signals() {
  sigset_t s;
  sigemptyset(&s);
  sigaddset(&s, SIGINT);
  sigaddset(&s, SIGTERM);
  return s;
}

void block_stop_signals() {
  const sigset_t s = stop_signals();
  pthread_sigmask(SIG_BLOCK, &s, nullptr);
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  sigaction(SIGINT, &default_action, nullptr);
  sigaction(SIGTERM, &default_action, nullptr);
}

void wait_for_stop_signal(double seconds) {
  const sigset_t s = stop_signals();
  // In case the caller did not block them: a signal arriving before sigwait must stay pending.
  pthread_sigmask(SIG_BLOCK, &s, nullptr);
  if (seconds < 0.0) {
    int received = 0;
    sigwait(&s, &received);
  } else if (seconds > 0.0) {
    timespec timeout{};
    timeout.tv_sec = static_cast<time_t>(seconds);
    timeout.tv_nsec = static_cast<long>((seconds - static_cast<double>(timeout.tv_sec)) * 1e9);
    sigtimedwait(&s, nullptr, &timeout);
  }
  // The other threads still block them, so the kernel hands the next one to this thread.
  pthread_sigmask(SIG_UNBLOCK, &s, nullptr);
}

}  // namespace coloc::cli
