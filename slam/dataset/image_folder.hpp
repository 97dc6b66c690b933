#pragma once
// Images of a folder tree that is not (necessarily) a sequence: what `coloc vocab train` learns
// its vocabulary from (any mix of TUM, 7-Scenes, RealSense recordings or photo folders).

#include <cstddef>
#include <filesystem>
#include <vector>

namespace coloc::dataset {

// Colour/grey images under `dir` (recursively), sorted by path: .png/.jpg/.jpeg files, except
// depth images (a path component or file name below `dir` containing "depth", as TUM's depth/,
// 7-Scenes' *.depth.png and RealSense's depths/ are named). Throws coloc::Error naming `dir`
// when it is not a readable folder.
std::vector<std::filesystem::path> find_colour_images(const std::filesystem::path& dir);

// Every `stride`-th element (the first, then stride later, ...); stride 0 counts as 1.
std::vector<std::filesystem::path> every_nth(const std::vector<std::filesystem::path>& paths,
                                             std::size_t stride);

}  // namespace coloc::dataset
