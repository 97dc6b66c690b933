#include "slam/dataset/image_folder.hpp"

#include <algorithm>
#include <cctype>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::dataset {
namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

std::vector<fs::path> find_colour_images(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw Error("not a folder", {.file = dir.string()});
  std::vector<fs::path> images;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    const std::string ext = lower(it->path().extension().string());
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") continue;
    // Only the part below `dir` decides: a user's folder may itself be called "depth_study".
    const std::string relative = lower(fs::relative(it->path(), dir).string());
    if (relative.find("depth") != std::string::npos) continue;
    images.push_back(it->path());
  }
  if (ec) throw Error("cannot list the folder: " + ec.message(), {.file = dir.string()});
  std::sort(images.begin(), images.end());
  return images;
}

std::vector<fs::path> every_nth(const std::vector<fs::path>& paths, std::size_t stride) {
  stride = std::max<std::size_t>(stride, 1);
  std::vector<fs::path> out;
  for (std::size_t i = 0; i < paths.size(); i += stride)
    out.push_back(paths[i]);
  return out;
}

}  // namespace coloc::dataset
