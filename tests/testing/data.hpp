#pragma once
// Where tests find the real recordings of ../shared/data (see its README).

#include <filesystem>

namespace coloc::testing {

// $COLOC_DATA if set, else <repo>/../shared/data.
std::filesystem::path shared_data_dir();

// shared_data_dir() / relative; empty path when it does not exist.
std::filesystem::path shared_data(const std::filesystem::path& relative);

// A file of the source tree: $COLOC_SOURCE_DIR (set by ctest) / relative, else this build's
// source directory / relative.
std::filesystem::path source_file(const std::filesystem::path& relative);

// A fresh, empty temporary directory, unique to this process and test (removed and recreated
// on each call). Callers remove it when they want to; /tmp is cleaned by the system.
std::filesystem::path temp_dir(const std::string& name);

}  // namespace coloc::testing

// Skips the current test (with a message saying what is missing) when a shared dataset is absent.
#define COLOC_REQUIRE_DATA(var, relative)                                       \
  const std::filesystem::path var = ::coloc::testing::shared_data(relative);    \
  if (var.empty()) {                                                            \
    GTEST_SKIP() << "shared data '" << (relative) << "' not found under "       \
                 << ::coloc::testing::shared_data_dir() << " (set COLOC_DATA)"; \
  }
