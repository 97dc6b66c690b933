#include "slam/core/error.hpp"

#include <sstream>

namespace coloc {

std::string format_error(const std::string& message, const ErrorContext& context) {
  // An ostringstream rather than string concatenation: GCC 12 reports a false -Wrestrict on
  // chained std::string operator+ (GCC bug 105329).
  std::ostringstream out;
  if (!context.file.empty()) {
    out << context.file;
    if (context.line) out << ':' << *context.line;
    out << ": ";
  } else if (context.line) {
    out << "line " << *context.line << ": ";
  }
  if (!context.field.empty()) out << "field '" << context.field << "': ";
  if (context.offset) out << "at offset " << *context.offset << ": ";
  out << message;
  return out.str();
}

Error::Error(const std::string& message, ErrorContext context)
    : std::runtime_error(format_error(message, context)),
      message_(message),
      context_(std::move(context)) {}

}  // namespace coloc
