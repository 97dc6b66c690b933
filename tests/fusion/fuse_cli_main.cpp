// A minimal `coloc` with only the fuse verb, so the verb is built and run by the fusion tests
// without building every other module's CLI dependencies.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("coloc"));  // stdout stays for results
  CLI::App app{"coloc (fuse verb only, for tests)"};
  app.require_subcommand(1);
  CLI::App& bench = *app.add_subcommand("bench", "Measure speed (prints figures)");
  bench.require_subcommand(1);
  coloc::cli::add_fuse_verb(app, bench);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
