#include "slam/core/input_file.hpp"

#include <unistd.h>

#include <string>
#include <system_error>

#include "slam/core/error.hpp"

namespace coloc {

namespace fs = std::filesystem;

namespace {

const char* kind_of(fs::file_type type) {
  switch (type) {
    case fs::file_type::directory:
      return "a directory";
    case fs::file_type::fifo:
      return "a FIFO (named pipe)";
    case fs::file_type::socket:
      return "a socket";
    case fs::file_type::character:
      return "a character device";
    case fs::file_type::block:
      return "a block device";
    case fs::file_type::regular:
      return "a regular file";
    default:
      return "not a regular file";
  }
}

fs::file_type type_of(const fs::path& path, std::string_view what) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (status.type() == fs::file_type::not_found || (ec && !fs::exists(status))) {
    throw Error(std::string(what) + " not found", {.file = path.string()});
  }
  if (ec) throw Error(std::string(what) + ": " + ec.message(), {.file = path.string()});
  return status.type();
}

}  // namespace

void check_input_file(const fs::path& path, std::string_view what) {
  const fs::file_type type = type_of(path, what);
  if (type != fs::file_type::regular) {
    throw Error(std::string(what) + " is " + kind_of(type) + ", not a regular file",
                {.file = path.string()});
  }
  if (::access(path.c_str(), R_OK) != 0)
    throw Error(std::string(what) + " is not readable (permissions)", {.file = path.string()});
}

void check_input_directory(const fs::path& path, std::string_view what) {
  const fs::file_type type = type_of(path, what);
  if (type != fs::file_type::directory) {
    throw Error(std::string(what) + " is " + kind_of(type) + ", not a directory",
                {.file = path.string()});
  }
}

}  // namespace coloc
