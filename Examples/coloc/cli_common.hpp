#pragma once
// Small helpers shared by the CLI verbs: exit-code carrying failures, JSON output, and where
// the CLI's own data and the recordings are.

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <stdexcept>
#include <string>

namespace coloc::cli {

// Degrees in one radian: the CLI prints angles in degrees.
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Thrown by a verb that ran but whose result is a failure (exit code 1) with a message that
// has already been decided; distinct from coloc::Error which names an input problem.
class CliFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// JSON documents keep their keys in insertion order, so --json output reads like the text.
using Json = nlohmann::ordered_json;

// Prints `document` on stdout as one line. Non-finite numbers become null; bytes that are not
// UTF-8 (e.g. in file names) are replaced rather than failing the verb after its work.
void print_json(const Json& document);

// A matrix as nested rows ([[m00, m01, ...], [m10, ...], ...]).
Json json_rows(const Eigen::MatrixXd& m);
// A matrix as one flat row-major array.
Json json_row_major(const Eigen::MatrixXd& m);

// The data the CLI ships with (vocabulary/, settings/, web/, plot.py): $COLOC_DATA_DIR, else
// share/coloc beside the folder of this executable (PREFIX/bin/coloc -> PREFIX/share/coloc;
// the build tree mirrors that layout). Never the source tree: an installed coloc runs alone.
std::filesystem::path data_dir();
// `relative` inside data_dir(); throws coloc::Error naming the path and COLOC_DATA_DIR when it
// is missing (a broken install says so instead of failing later on an unreadable file).
std::filesystem::path data_file(const std::filesystem::path& relative);
// The shipped ORB vocabulary.
std::filesystem::path shipped_vocabulary();

// The real recordings (TUM, 7-Scenes, EuRoC, ...): $COLOC_DATA; empty when it is not set.
std::filesystem::path recordings_dir();

}  // namespace coloc::cli
