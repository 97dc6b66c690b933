// The one YAML guard every reader goes through: the input OpenCV 4.6's reader loops forever on
// ("----x"), binary data, FIFOs and directories are errors naming the file (and line), at once.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <string>
#include <utility>
#include <vector>

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

// Each of these hung OpenCV 4.6's cv::FileStorage (its root collection ends before the end of
// the file); each is refused with its line, and the files we ship still pass.
TEST(YamlText, RefusesARootThatEndsBeforeTheFile) {
  const fs::path dir = testing::temp_dir("yaml_text_root");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"%YAML:1.0\n -A\nA\n-", ":2"},               // found by scripts/fuzz_yaml
      {"%YAML:1.0\n----x\n", ":2"},                 // found by scripts/fuzz_settings
      {"%YAML:1.0\n--- a: 1\n", ":2"},              // root on the marker's line
      {"%YAML:1.0\n---\n{a: 1}\n---\n-x\n", ":3"},  // flow root
      {"%YAML:1.0\na: 1\n...\n-x\n", ":3"},         // document end
      {"%YAML:1.0\na: 1\n---\nb: 2\n", ":3"},       // second document
  };
  for (const auto& [text, line] : cases) {
    std::ofstream(dir / "bad.yaml", std::ios::trunc) << text;
    EXPECT_NE(message_of(dir / "bad.yaml").find(line), std::string::npos) << text;
  }
  const std::string ok =
      "%YAML:1.0\n\n# comment\n  # indented comment\n---  # marker\n\nCamera.fx: 1\n"
      "list:\n  - { id: 3 }\n  - [1, 2]\n";
  std::ofstream(dir / "ok.yaml", std::ios::trunc) << ok;
  EXPECT_EQ(read_yaml_text(dir / "ok.yaml", "marker map"), ok);
  // OpenCV reads these as JSON and XML, not YAML.
  for (const std::string other : {"{\n  \"a\": 1\n}\n", "<?xml version=\"1.0\"?>\n<a>1</a>\n"}) {
    std::ofstream(dir / "other.yaml", std::ios::trunc) << other;
    EXPECT_EQ(read_yaml_text(dir / "other.yaml", "marker map"), other);
  }
  // The shipped settings and the ORB-SLAM files users bring (when the shared data is there).
  for (const fs::path& folder : {fs::path(COLOC_TEST_SOURCE_DIR) / "Examples" / "RGB-D",
                                 testing::shared_data("orbslam_configs")}) {
    if (folder.empty()) continue;
    for (const auto& entry : fs::directory_iterator(folder)) {
      if (entry.path().extension() == ".yaml") {
        EXPECT_NO_THROW(read_yaml_text(entry.path(), "settings file")) << entry.path();
      }
    }
  }
}

}  // namespace
}  // namespace coloc
