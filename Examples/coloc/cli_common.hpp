#pragma once
// Small helpers shared by the CLI verbs: exit-code carrying failures, JSON output, and where
// the repository and the shared data are.

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace coloc::cli {

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

// The repository (shipped vocabulary, camera files, plot script): $COLOC_SOURCE_DIR, else the
// source tree this binary was built from.
std::filesystem::path source_dir();

// The shared real recordings: $COLOC_DATA, else ../shared/data next to the repository.
std::filesystem::path default_data_dir();

}  // namespace coloc::cli
