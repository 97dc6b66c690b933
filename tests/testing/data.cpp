#include "tests/testing/data.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace coloc::testing {

std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("COLOC_DATA"); env != nullptr && *env != '\0') {
    return env;
  }
  return std::filesystem::path(COLOC_SOURCE_DIR).parent_path() / "shared" / "data";
}

std::filesystem::path shared_data(const std::filesystem::path& relative) {
  std::filesystem::path p = shared_data_dir() / relative;
  return std::filesystem::exists(p) ? p : std::filesystem::path{};
}

std::filesystem::path source_file(const std::filesystem::path& relative) {
  if (const char* env = std::getenv("COLOC_SOURCE_DIR"); env != nullptr && *env != '\0')
    return std::filesystem::path(env) / relative;
  return std::filesystem::path(COLOC_SOURCE_DIR) / relative;
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  // ctest runs every test in its own process, several at once: the process id keeps two
  // processes (e.g. two suites' SetUpTestSuite, where there is no current test) apart.
  std::string unique = name + "_" + std::to_string(::getpid());
  if (info != nullptr) unique += std::string("_") + info->test_suite_name() + "_" + info->name();
  std::filesystem::path dir = std::filesystem::temp_directory_path() / "coloc_tests" / unique;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace coloc::testing
