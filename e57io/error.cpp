#include "e57io/error.hpp"

#include <sstream>

namespace coloc::e57 {

std::string format_error(const std::string& message, const ErrorContext& context) {
  std::ostringstream out;
  out << "e57: " << message;
  std::string sep = " [";
  auto part = [&](const std::string& text) {
    out << sep << text;
    sep = ", ";
  };
  if (!context.file.empty()) part("file '" + context.file + "'");
  if (context.page) part("page " + std::to_string(*context.page));
  if (context.physical_offset) part("physical offset " + std::to_string(*context.physical_offset));
  if (context.logical_offset) part("logical offset " + std::to_string(*context.logical_offset));
  if (!context.element.empty()) part("element '" + context.element + "'");
  if (sep == ", ") out << ']';
  return out.str();
}

Error::Error(const std::string& message, ErrorContext context)
    : std::runtime_error(format_error(message, context)),
      message_(message),
      context_(std::move(context)) {}

}  // namespace coloc::e57
