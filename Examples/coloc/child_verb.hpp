#pragma once
// This program's own verbs run as child processes: the demo and `coloc bench site` chain them as
// a user would, printing each command first so any step can be repeated by hand. A child is
// `/proc/self/exe`, so the chain runs the very build that was started.

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "Examples/coloc/cli_common.hpp"

namespace coloc::cli {

// A verb started by another coloc (start_verb and friends) ends with it: `coloc bench site`
// stopped by a signal, a timeout or a crash must not leave a registration running for half an
// hour. Called first thing in main(); false when the starting process is already gone.
bool follow_parent();

// "coloc ARG ARG ..." as printed before a step.
std::string shown_command(const std::vector<std::string>& args);

// Starts `coloc ARGS...`, printing the command first (" &" when the caller goes on without
// waiting); throws CliFailure when it cannot start.
pid_t start_verb(const std::vector<std::string>& args, bool background = false);
// Waits for a started verb; throws CliFailure naming `shown` when it failed.
void wait_verb(pid_t pid, const std::string& shown);
// Runs `coloc ARGS...` and waits; throws CliFailure when it fails.
void run_verb(const std::vector<std::string>& args);
// Runs `coloc ARGS... --json` with its stdout captured and waits; throws CliFailure when it
// fails or prints no JSON.
Json capture_verb(std::vector<std::string> args);
// Ends a verb started in the background (SIGINT, as a user would) and waits for it.
void stop_verb(pid_t pid, const std::string& shown);

// What one verb cost, from the kernel's accounting of the child (wait4): wall time, CPU time of
// all its threads, and its peak resident memory.
struct VerbCost {
  double wall_s = 0.0;
  double cpu_s = 0.0;  // user + system
  std::uint64_t peak_rss_bytes = 0;
};

// capture_verb (with `json` true) or run_verb, measured.
VerbCost measure_verb(std::vector<std::string> args, bool json, Json* document = nullptr);

}  // namespace coloc::cli
