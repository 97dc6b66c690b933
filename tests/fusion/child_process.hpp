#pragma once
// A child process for the OSC tests (liblo-tools' oscsend/oscdump as independent peers), with
// every wait bounded so a test can fail but never hang.

#include <sys/types.h>

#include <string>
#include <vector>

namespace coloc::fusion::testing {

class ChildProcess {
 public:
  // Starts argv[0] (searched in PATH) with its stdout on a pipe; throws std::runtime_error.
  explicit ChildProcess(const std::vector<std::string>& argv);
  ~ChildProcess();  // kills (SIGTERM) and reaps the child if still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Reads one stdout line, waiting at most timeout_ms; empty optional-like "" plus false on
  // timeout or end of file.
  bool read_line(std::string& line, int timeout_ms);
  // Waits at most timeout_ms for exit; returns the exit status, or -1 on timeout.
  int wait(int timeout_ms);

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string pending_;
};

// Runs a command to completion (at most timeout_ms) and returns its exit status (-1: timeout).
// The default only stops a stuck command: a busy machine may take seconds to start one.
int run(const std::vector<std::string>& argv, int timeout_ms = 60000);

// True when `tool` is found in PATH.
bool have_tool(const std::string& tool);

}  // namespace coloc::fusion::testing
