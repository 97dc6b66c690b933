#include "Examples/coloc/plot.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "Examples/coloc/cli_common.hpp"
#include "slam/core/error.hpp"

// Set by Examples/coloc/CMakeLists.txt: the python3 found at configure time ("" if none).
#ifndef COLOC_PYTHON3
#define COLOC_PYTHON3 ""
#endif

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

// Exit code of plot.py when `import matplotlib` fails.
constexpr int kMatplotlibMissing = 3;

std::string format_of(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext.empty() ? ext : ext.substr(1);
}

Json describe(const std::vector<Panel>& panels) {
  Json out = Json::array();
  for (const Panel& p : panels) {
    Json series = Json::array();
    for (const Series& s : p.series) {
      Json x = Json::array(), y = Json::array();
      for (const Eigen::Vector2d& v : s.points) {
        x.push_back(v.x());
        y.push_back(v.y());
      }
      series.push_back({{"label", s.label}, {"x", x}, {"y", y}, {"colour", s.colour}});
    }
    out.push_back({{"title", p.title},
                   {"x_label", p.x_label},
                   {"y_label", p.y_label},
                   {"equal_aspect", p.equal_aspect},
                   {"series", series}});
  }
  return {{"panels", out}};
}

// A temporary file (created, closed) whose name ends in `suffix`; the caller removes it.
fs::path temp_file(const std::string& suffix) {
  std::string name = (fs::temp_directory_path() / ("coloc_plot_XXXXXX" + suffix)).string();
  const int fd = mkstemps(name.data(), static_cast<int>(suffix.size()));
  if (fd < 0) throw Error("cannot create a temporary file", {.file = name});
  close(fd);
  return name;
}

// The script's messages, without the trailing newline (they end an error message).
std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.pop_back();
  return text;
}

// Runs `argv` with stdout and stderr into `log` (stdout stays clean for --json); returns the
// exit status (-1 when it did not exit normally).
int run_logged(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<char*> argv;
  std::vector<std::string> store = args;
  for (auto& a : store)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_TRUNC, 0);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

// Files removed when the plot is done, however it ends.
struct TempFiles {
  std::vector<fs::path> paths;
  ~TempFiles() {
    std::error_code ignored;
    for (const auto& p : paths)
      fs::remove(p, ignored);
  }
};

}  // namespace

void check_plot_path(const fs::path& path) {
  const std::string format = format_of(path);
  if (format != "png" && format != "pdf" && format != "svg")
    throw Error("a plot must be a .png, .pdf or .svg file", {.file = path.string()});
  if (fs::is_directory(path)) throw Error("the plot path is a folder", {.file = path.string()});
  const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  if (!fs::is_directory(dir))
    throw Error("the plot's folder does not exist", {.file = path.string()});
  // The plot is written next to its final name and renamed: the folder must take new files.
  if (access(dir.c_str(), W_OK | X_OK) != 0)
    throw Error("the plot's folder is not writable", {.file = path.string()});
}

void write_plot(const fs::path& path, const std::vector<Panel>& panels) {
  check_plot_path(path);
  const std::string python = COLOC_PYTHON3;
  if (python.empty() || access(python.c_str(), X_OK) != 0)
    throw Error("python3 not found (looked for at configure time: '" + python +
                    "'): install python3 and python3-matplotlib (scripts/install_deps.sh), "
                    "then re-run cmake",
                {.file = path.string()});
  const fs::path script = data_file("plot.py");
  if (!fs::exists(script)) throw Error("plot script not found", {.file = script.string()});

  const fs::path description = temp_file(".json");
  const fs::path log = temp_file(".log");
  // Hidden, unique and in the final folder, so the rename is atomic.
  std::string partial_name = ".";
  partial_name += path.filename().string();
  partial_name += ".partial-" + std::to_string(getpid());
  const fs::path partial = path.parent_path() / partial_name;
  const TempFiles temp{{description, log, partial}};
  {
    std::ofstream out(description);
    out << describe(panels).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    if (!out) throw Error("cannot write the plot description", {.file = description.string()});
  }
  const int status = run_logged({python, script.string(), description.string(), partial.string(),
                                 "--format", format_of(path)},
                                log);
  if (status == kMatplotlibMissing)
    throw Error(
        "matplotlib is missing: install the Debian package python3-matplotlib "
        "(scripts/install_deps.sh does this): " +
            read_text(log),
        {.file = path.string()});
  if (status != 0) {
    std::ostringstream message;
    message << "the plot script failed (" << script.string() << ", exit " << status
            << "): " << read_text(log);
    throw Error(message.str(), {.file = path.string()});
  }
  std::error_code ec;
  fs::rename(partial, path, ec);
  if (ec)
    throw Error("cannot rename the finished plot into place: " + ec.message(),
                {.file = path.string()});
}

}  // namespace coloc::cli
