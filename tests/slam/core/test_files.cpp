// Issue 17: the one way outputs are written (AtomicOutput / write_file_atomically), the checks
// every input path gets before it is opened, and trajectories that contradict themselves.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/trajectory.hpp"
#include "tests/testing/data.hpp"

namespace coloc {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::size_t entries(const fs::path& dir) {
  return static_cast<std::size_t>(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(AtomicOutput, AFailureMidwayLeavesTheOldFileAndNoDebris) {
  const fs::path dir = testing::temp_dir("atomic_output");
  const fs::path target = dir / "out.ply";
  write_file_atomically(target, std::string_view("good"));
  EXPECT_EQ(read_all(target), "good");
  try {
    AtomicOutput out(target);
    out << "half of a new fi";
    throw std::runtime_error("the reader failed midway");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(read_all(target), "good");
  EXPECT_EQ(entries(dir), 1u);
  write_file_atomically(target, [](std::ostream& out) { out << "better"; });
  EXPECT_EQ(read_all(target), "better");
  EXPECT_EQ(entries(dir), 1u);
}

TEST(AtomicOutput, AnUnwritableTargetFailsBeforeAnyWork) {
  const fs::path dir = testing::temp_dir("atomic_output_missing");
  try {
    AtomicOutput out(dir / "no_such_folder" / "x.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(AtomicOutput{dir}, Error);  // a directory is no output file
}

TEST(InputFile, WhatThePathIsIsNamedBeforeItIsOpened) {
  const fs::path dir = testing::temp_dir("input_file");
  const fs::path fifo = dir / "pipe";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto message = [](const fs::path& p) {
    try {
      check_input_file(p, "settings file");
    } catch (const Error& e) {
      EXPECT_EQ(e.context().file, p.string());
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message(fifo).find("settings file is a FIFO"), std::string::npos) << message(fifo);
  EXPECT_NE(message(dir).find("is a directory"), std::string::npos);
  EXPECT_NE(message(dir / "missing").find("not found"), std::string::npos);
  EXPECT_NE(message("/dev/null").find("character device"), std::string::npos);
  std::ofstream(dir / "ok") << "x";
  EXPECT_EQ(message(dir / "ok"), "");
  EXPECT_THROW(check_input_directory(dir / "ok", "sequence"), Error);
  EXPECT_NO_THROW(check_input_directory(dir, "sequence"));
  fs::remove(fifo);
}

TEST(TumTrajectory, TwoPosesForOneTimestampAreAnErrorNamingBothLines) {
  const fs::path dir = testing::temp_dir("tum_duplicates");
  std::ofstream(dir / "dup.txt") << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n1.0 0.5 0 0 0 0 0 1\n";
  try {
    read_tum_trajectory(dir / "dup.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 3);
    EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
  }
  // An exact repeat says nothing new and is dropped.
  std::ofstream(dir / "repeat.txt") << "1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n";
  EXPECT_EQ(read_tum_trajectory(dir / "repeat.txt").size(), 2u);
  std::ofstream(dir / "nan.txt") << "1.0 nan 0 0 0 0 0 1\n";
  EXPECT_THROW(read_tum_trajectory(dir / "nan.txt"), Error);
}

}  // namespace
}  // namespace coloc
