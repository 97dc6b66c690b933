#pragma once
// coloc::e57::Error: the one exception type of e57io. e57io knows nothing else of coloc (DESIGN.md
// section 2), so it carries its own context: the file, where in it (physical and logical byte
// offsets, page number) and which element of the XML tree, all formatted into what().

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace coloc::e57 {

struct ErrorContext {
  std::string file;                              // path of the E57 file, if known
  std::optional<std::uint64_t> physical_offset;  // byte offset in the file as stored
  std::optional<std::uint64_t> logical_offset;   // byte offset without the page CRCs
  std::optional<std::uint64_t> page;             // 0-based page number (1024-byte pages)
  std::string element;                           // element path, e.g. "/data3D/0/points"
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

// "message [file 'x', page 3, physical offset 3100, logical offset 3088, element '/a/b']".
std::string format_error(const std::string& message, const ErrorContext& context);

}  // namespace coloc::e57
