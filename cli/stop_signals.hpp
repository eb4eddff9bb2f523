// SIGINT and SIGTERM as a request to stop (fit, sweep): the work under way ends cleanly and
// saves what it has instead of the process ending at once.
#pragma once

#include <atomic>
#include <csignal>

namespace btfgmm::cli {

// Set by SIGINT / SIGTERM while a StopOnSignals lives.
inline std::atomic<bool> g_stop{false};

}  // namespace btfgmm::cli

extern "C" inline void btfgmm_cli_on_stop_signal(int) {
  btfgmm::cli::g_stop.store(true);
}

namespace btfgmm::cli {

// While it lives, SIGINT and SIGTERM set g_stop instead of ending the process.
class StopOnSignals {
 public:
  StopOnSignals() {
    g_stop.store(false);
    std::signal(SIGINT, btfgmm_cli_on_stop_signal);
    std::signal(SIGTERM, btfgmm_cli_on_stop_signal);
  }
  ~StopOnSignals() {
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;
};

}  // namespace btfgmm::cli
