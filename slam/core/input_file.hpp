#pragma once
// What an input path is, checked before it is opened. Opening a FIFO for reading blocks until
// a writer appears (forever, for a settings path mistyped into a pipe), a directory "opens" and
// then reads as garbage or as an empty file, and a character device may never end. Every reader
// in coloc calls these first, so such paths are a coloc::Error naming the file and what it is.

#include <filesystem>
#include <string_view>

namespace coloc {

// Throws coloc::Error (file named, `what` says which input, e.g. "settings file") unless `path`
// is, after following symlinks, an existing regular file we may read.
void check_input_file(const std::filesystem::path& path, std::string_view what);
// The same for a folder input (a sequence, an image folder).
void check_input_directory(const std::filesystem::path& path, std::string_view what);

}  // namespace coloc
