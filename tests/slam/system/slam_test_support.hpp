#pragma once
// Shared by the SLAM system tests: the shipped vocabulary (loaded once per test binary) and the
// source tree it is read from.
#include <cstdlib>
#include <filesystem>

#include "slam/bow/vocabulary.hpp"

namespace coloc::slam::test_support {

inline std::filesystem::path source_dir() {
  if (const char* env = std::getenv("COLOC_SOURCE_DIR")) return env;
  return COLOC_TEST_SOURCE_DIR;
}

// Loaded once per binary (an inline function's static is shared by every test file): the
// vocabulary takes a moment to read.
inline const bow::Vocabulary& vocabulary() {
  static const bow::Vocabulary v =
      bow::Vocabulary::load(source_dir() / "Vocabulary/coloc_orb_k10_L5.cvoc");
  return v;
}

}  // namespace coloc::slam::test_support
