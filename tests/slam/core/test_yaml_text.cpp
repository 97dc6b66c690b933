// The one YAML guard every reader goes through: the input OpenCV 4.6's reader loops forever on
// ("----x"), binary data, FIFOs and directories are errors naming the file (and line), at once.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "slam/core/error.hpp"
#include "slam/core/yaml_text.hpp"
#include "tests/testing/data.hpp"

namespace coloc {
namespace {

namespace fs = std::filesystem;

std::string message_of(const fs::path& path, const YamlTextOptions& options = {}) {
  try {
    read_yaml_text(path, "marker map", options);
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, path.string());
    return e.what();
  }
  return "";
}

TEST(YamlText, RefusesWhatHangsOrIsNotAFile) {
  const fs::path dir = testing::temp_dir("yaml_text");
  std::ofstream(dir / "ok.yaml") << "%YAML:1.0\n---\nformat: x\n";
  EXPECT_EQ(read_yaml_text(dir / "ok.yaml", "marker map"), "%YAML:1.0\n---\nformat: x\n");
  std::ofstream(dir / "loop.yaml") << "%YAML:1.0\n---\nformat: x\n----x\n";
  EXPECT_NE(message_of(dir / "loop.yaml").find(":4"), std::string::npos);
  EXPECT_NE(message_of(dir / "loop.yaml").find("'---'"), std::string::npos);
  std::ofstream(dir / "nul.yaml") << std::string("a: 1\n\0b: 2\n", 11);
  EXPECT_NE(message_of(dir / "nul.yaml").find("NUL"), std::string::npos);
  std::ofstream(dir / "big.yaml") << std::string(2048, '#');
  EXPECT_NE(message_of(dir / "big.yaml", {.max_bytes = 1024}).find("larger than"),
            std::string::npos);
  ASSERT_EQ(::mkfifo((dir / "fifo.yaml").c_str(), 0600), 0);
  EXPECT_NE(message_of(dir / "fifo.yaml").find("marker map is a FIFO"), std::string::npos);
  fs::create_directories(dir / "folder.yaml");
  EXPECT_NE(message_of(dir / "folder.yaml").find("is a directory"), std::string::npos);
  EXPECT_NE(message_of(dir / "missing.yaml").find("not found"), std::string::npos);
}

}  // namespace
}  // namespace coloc
