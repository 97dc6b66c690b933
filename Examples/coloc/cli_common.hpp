#pragma once
// Small helpers shared by the CLI verbs: exit-code carrying failures and JSON output.

#include <stdexcept>
#include <string>

namespace coloc::cli {

// Thrown by a verb that ran but whose result is a failure (exit code 1) with a message that
// has already been decided; distinct from coloc::Error which names an input problem.
class CliFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Quotes and escapes a string for JSON output.
std::string json_string(const std::string& s);

// Formats a double for JSON (finite numbers with 9 significant digits, null otherwise).
std::string json_number(double v);

}  // namespace coloc::cli
