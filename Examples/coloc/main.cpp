// coloc: the command-line tool. Exit codes: 0 success, 1 failure (bad input, failed run),
// 2 usage error. Results go to stdout (text or --json), logs and progress to stderr.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <string>

#include "Examples/coloc/child_verb.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"
#include "slam/core/version.hpp"

int main(int argc, char** argv) {
  if (!coloc::cli::follow_parent()) return 1;
  // Logs go to stderr so stdout stays machine-readable.
  spdlog::set_default_logger(spdlog::stderr_color_mt("coloc"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App app{"coloc: co-location of XR users with laser-scanned buildings"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "coloc " + std::string(coloc::version()) + " (git " +
                                        std::string(coloc::git_hash()) + ")");
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Debug logging");
  app.parse_complete_callback([&] {
    if (verbose) spdlog::set_level(spdlog::level::debug);
  });

  // `coloc bench <what>`: speed figures (docs/design.md, targets); each module adds its own.
  CLI::App& bench = *app.add_subcommand("bench", "Measure speed (prints figures)");
  bench.require_subcommand(1);

  coloc::cli::add_demo_verb(app);
  coloc::cli::add_eval_verb(app);
  coloc::cli::add_vocab_verb(app, bench);
  coloc::cli::add_map_verb(app, bench);
  coloc::cli::add_localize_verb(app, bench);
  coloc::cli::add_loop_bench_verb(bench);
  coloc::cli::add_mapdb_verb(app, bench);
  coloc::cli::add_e57_verb(app, bench);
  coloc::cli::add_markers_verb(app, bench);
  coloc::cli::add_twin_verb(app, bench);
  coloc::cli::add_handeye_verb(app, bench);
  coloc::cli::add_fuse_verb(app, bench);
  coloc::cli::add_register_verb(app);
  coloc::cli::add_scan_verb(app);
  coloc::cli::add_session_verb(app, bench);
  coloc::cli::add_view_verb(app, bench);
  coloc::cli::add_capture_verb(app, bench);
  coloc::cli::add_record_verb(app);
  coloc::cli::add_calibrate_verb(app);
  coloc::cli::add_bench_site_verb(bench);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const coloc::Error& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  } catch (const coloc::cli::CliFailure& e) {
    std::cerr << "failed: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
