#pragma once
// coloc::Error: the one exception type thrown at IO and API boundaries. It carries where the
// problem is (file, field, byte offset or line) so a user can fix the input. Algorithm outcomes
// (tracking lost, BA not converged) are values, never exceptions.

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace coloc {

struct ErrorContext {
  std::string file;                     // path of the offending file, if any
  std::string field;                    // key, element or column name, if any
  std::optional<std::uint64_t> offset;  // byte offset into the file, if known
  std::optional<std::int64_t> line;     // 1-based line number, if known
};

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message, ErrorContext context = {});

  // The message without context.
  const std::string& message() const { return message_; }
  const ErrorContext& context() const { return context_; }

 private:
  std::string message_;
  ErrorContext context_;
};

// Formats "file:line: field 'x': at offset N: message" with whatever context is present.
std::string format_error(const std::string& message, const ErrorContext& context);

}  // namespace coloc
