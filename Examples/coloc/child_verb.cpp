#include "Examples/coloc/child_verb.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "slam/core/timing.hpp"

namespace coloc::cli {
namespace {

constexpr std::string_view kParentVariable = "COLOC_PARENT_PID";

// Starts `coloc ARGS...` (this very executable) with `actions` (null: none) on its file
// descriptors; throws CliFailure when it cannot start.
pid_t spawn_self(const std::vector<std::string>& args, const posix_spawn_file_actions_t* actions) {
  std::vector<std::string> argv_store = {"coloc"};
  argv_store.insert(argv_store.end(), args.begin(), args.end());
  std::vector<char*> argv;
  argv.reserve(argv_store.size() + 1);
  for (auto& a : argv_store)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  // The child's environment names this process (follow_parent()).
  const std::string prefix = std::string(kParentVariable) + "=";
  std::vector<std::string> env_store;
  for (char** e = environ; *e != nullptr; ++e)
    if (!std::string_view(*e).starts_with(prefix)) env_store.emplace_back(*e);
  env_store.push_back(prefix + std::to_string(getpid()));
  std::vector<char*> env;
  env.reserve(env_store.size() + 1);
  for (auto& e : env_store)
    env.push_back(e.data());
  env.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, "/proc/self/exe", actions, nullptr, argv.data(), env.data()) != 0)
    throw CliFailure("cannot start: " + shown_command(args));
  return pid;
}

// Waits for `pid`; its resource use goes to `usage` (may be null).
void wait_child(pid_t pid, const std::string& shown, rusage* usage) {
  int status = 0;
  if (wait4(pid, &status, 0, usage) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw CliFailure("step failed: " + shown);
}

// Runs `coloc ARGS...` with its stdout captured and waits.
std::string run_captured(const std::vector<std::string>& args, rusage* usage) {
  const std::string shown = shown_command(args);
  std::printf("  $ %s\n", shown.c_str());
  std::fflush(stdout);
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw CliFailure("cannot start: " + shown);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  pid_t pid = -1;
  try {
    pid = spawn_self(args, &actions);
  } catch (...) {
    posix_spawn_file_actions_destroy(&actions);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    throw;
  }
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  std::string out;
  char buffer[4096];
  ssize_t n = 0;
  while ((n = read(pipe_fds[0], buffer, sizeof(buffer))) > 0)
    out.append(buffer, static_cast<std::size_t>(n));
  close(pipe_fds[0]);
  wait_child(pid, shown, usage);
  return out;
}

Json parse_json(const std::string& text, const std::string& shown) {
  Json document = Json::parse(text, nullptr, false);
  if (document.is_discarded()) throw CliFailure("no JSON from: " + shown);
  return document;
}

double seconds(const timeval& t) {
  return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
}

}  // namespace

bool follow_parent() {
  const char* parent = std::getenv(std::string(kParentVariable).c_str());
  if (parent == nullptr) return true;
  // SIGTERM when the thread that started us ends; a parent gone before this call is seen as a
  // changed parent id (we were re-parented).
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  return std::to_string(getppid()) == parent;
}

std::string shown_command(const std::vector<std::string>& args) {
  std::string shown = "coloc";
  for (const auto& a : args)
    shown += " " + a;
  return shown;
}

pid_t start_verb(const std::vector<std::string>& args, bool background) {
  std::printf("  $ %s%s\n", shown_command(args).c_str(), background ? " &" : "");
  std::fflush(stdout);
  return spawn_self(args, nullptr);
}

void wait_verb(pid_t pid, const std::string& shown) {
  wait_child(pid, shown, nullptr);
}

void run_verb(const std::vector<std::string>& args) {
  wait_verb(start_verb(args), shown_command(args));
}

Json capture_verb(std::vector<std::string> args) {
  args.emplace_back("--json");
  return parse_json(run_captured(args, nullptr), shown_command(args));
}

void stop_verb(pid_t pid, const std::string& shown) {
  kill(pid, SIGINT);
  wait_verb(pid, shown);
}

VerbCost measure_verb(std::vector<std::string> args, bool json, Json* document) {
  rusage usage{};
  const Stopwatch watch;
  if (json) {
    args.emplace_back("--json");
    const std::string out = run_captured(args, &usage);
    const Json parsed = parse_json(out, shown_command(args));
    if (document) *document = parsed;
  } else {
    wait_child(start_verb(args), shown_command(args), &usage);
  }
  VerbCost cost;
  cost.wall_s = watch.elapsed_seconds();
  cost.cpu_s = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  cost.peak_rss_bytes = static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;  // kB on Linux
  return cost;
}

}  // namespace coloc::cli
