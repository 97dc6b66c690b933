#include "registration/twin/textures.hpp"

#include <array>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

using Rng = std::mt19937_64;

int uniform_int(Rng& rng, int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}
double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

cv::Scalar random_colour(Rng& rng, int lo, int hi) {
  return cv::Scalar(uniform_int(rng, lo, hi), uniform_int(rng, lo, hi), uniform_int(rng, lo, hi));
}

// Smooth value noise: random values on a coarse grid, bicubically upsampled with wrap-around so
// the texture tiles.
cv::Mat value_noise(Rng& rng, int size, int cells, double amplitude) {
  cv::Mat coarse(cells, cells, CV_32F);
  for (int r = 0; r < cells; ++r) {
    for (int c = 0; c < cells; ++c)
      coarse.at<float>(r, c) = static_cast<float>(uniform(rng, -1, 1));
  }
  cv::Mat padded;
  cv::copyMakeBorder(coarse, padded, 2, 2, 2, 2, cv::BORDER_WRAP);
  const double scale = static_cast<double>(size) / cells;
  cv::Mat big;
  cv::resize(padded, big, cv::Size(), scale, scale, cv::INTER_CUBIC);
  const int off = static_cast<int>(2 * scale);
  return big(cv::Rect(off, off, size, size)).clone() * amplitude;
}

void add_noise(cv::Mat& img, const cv::Mat& noise) {
  cv::Mat f;
  img.convertTo(f, CV_32FC3);
  std::vector<cv::Mat> ch;
  cv::split(f, ch);
  for (auto& c : ch)
    c += noise;
  cv::merge(ch, f);
  f.convertTo(img, CV_8UC3);
}

void speckle(Rng& rng, cv::Mat& img, int count, int lo, int hi, int max_radius) {
  for (int i = 0; i < count; ++i) {
    const cv::Point p(uniform_int(rng, 0, img.cols - 1), uniform_int(rng, 0, img.rows - 1));
    cv::circle(img, p, uniform_int(rng, 1, max_radius), random_colour(rng, lo, hi), cv::FILLED,
               cv::LINE_AA);
  }
}

// A poster / notice: coloured blocks, shapes and text lines (strong corners for ORB).
void draw_poster(Rng& rng, cv::Mat& img, cv::Rect r) {
  r &= cv::Rect(0, 0, img.cols, img.rows);
  if (r.width < 20 || r.height < 20) return;
  cv::rectangle(img, r, random_colour(rng, 150, 255), cv::FILLED);
  cv::rectangle(img, r, cv::Scalar(30, 30, 30), 2);
  const int shapes = uniform_int(rng, 4, 12);
  for (int i = 0; i < shapes; ++i) {
    const cv::Point a(uniform_int(rng, r.x, r.x + r.width - 1),
                      uniform_int(rng, r.y, r.y + r.height - 1));
    const cv::Point b(uniform_int(rng, r.x, r.x + r.width - 1),
                      uniform_int(rng, r.y, r.y + r.height - 1));
    const cv::Scalar c = random_colour(rng, 0, 255);
    switch (uniform_int(rng, 0, 2)) {
      case 0:
        cv::rectangle(img, a, b, c, cv::FILLED);
        break;
      case 1:
        cv::circle(img, a, std::max(3, std::abs(b.x - a.x) / 3), c, cv::FILLED, cv::LINE_AA);
        break;
      default:
        cv::line(img, a, b, c, uniform_int(rng, 2, 6), cv::LINE_AA);
    }
  }
  static constexpr std::array<const char*, 8> kWords{"EXIT",   "LAB 2", "MEETING", "FLOOR",
                                                     "NOTICE", "B-104", "SAFETY",  "ROOM"};
  const int lines = uniform_int(rng, 1, 4);
  for (int i = 0; i < lines; ++i) {
    const double scale = uniform(rng, 0.4, 1.2) * r.width / 200.0;
    const cv::Point at(r.x + uniform_int(rng, 2, std::max(3, r.width / 3)),
                       r.y + uniform_int(rng, r.height / 5, r.height - 4));
    cv::putText(img, kWords[static_cast<std::size_t>(uniform_int(rng, 0, 7))], at,
                cv::FONT_HERSHEY_SIMPLEX, std::max(0.3, scale), random_colour(rng, 0, 90),
                std::max(1, static_cast<int>(2 * scale)), cv::LINE_AA);
  }
}

cv::Mat plaster(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, random_colour(rng, 170, 235));
  add_noise(img, value_noise(rng, n, 8, 12.0));
  speckle(rng, img, n / 2, 120, 220, 2);
  const int posters = uniform_int(rng, 3, 7);
  for (int i = 0; i < posters; ++i) {
    const int w = uniform_int(rng, n / 10, n / 4);
    const int h = uniform_int(rng, n / 10, n / 4);
    draw_poster(rng, img, {uniform_int(rng, 0, n - w), uniform_int(rng, n / 8, n - h), w, h});
  }
  // Horizontal skirting and dado lines give long edges at known heights.
  cv::line(img, {0, n - 4}, {n, n - 4}, cv::Scalar(70, 60, 50), 8);
  return img;
}

cv::Mat brick(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, cv::Scalar(190, 185, 175));
  const int rows = 16;
  const int bh = n / rows;
  const int bw = bh * 2;
  const cv::Scalar base = random_colour(rng, 120, 190);
  for (int r = 0; r < rows; ++r) {
    const int off = (r % 2) * bw / 2;
    for (int x = -bw; x < n + bw; x += bw) {
      const cv::Scalar tone = base + cv::Scalar::all(uniform(rng, -35, 35));
      cv::rectangle(img, {x + off + 2, r * bh + 2}, {x + off + bw - 2, r * bh + bh - 2}, tone,
                    cv::FILLED);
    }
  }
  add_noise(img, value_noise(rng, n, 16, 10.0));
  speckle(rng, img, n, 60, 140, 1);
  return img;
}

cv::Mat wood(Rng& rng, int n) {
  const cv::Scalar base = random_colour(rng, 110, 190);
  cv::Mat img(n, n, CV_8UC3, base);
  const int planks = 8;
  const int pw = n / planks;
  for (int p = 0; p < planks; ++p) {
    const cv::Scalar tone = base + cv::Scalar::all(uniform(rng, -30, 30));
    cv::rectangle(img, {p * pw, 0}, {p * pw + pw - 1, n}, tone, cv::FILLED);
    for (int g = 0; g < 14; ++g) {
      const int x = p * pw + uniform_int(rng, 2, pw - 3);
      cv::line(img, {x, 0}, {x + uniform_int(rng, -6, 6), n}, tone * 0.75, 1, cv::LINE_AA);
    }
    const int joint = uniform_int(rng, 0, n - 1);
    cv::line(img, {p * pw, joint}, {p * pw + pw, joint}, cv::Scalar(40, 30, 20), 2);
    cv::line(img, {p * pw, 0}, {p * pw, n}, cv::Scalar(40, 30, 20), 2);
    cv::ellipse(img, {p * pw + pw / 2, uniform_int(rng, 0, n - 1)}, {pw / 6, pw / 4}, 0, 0, 360,
                tone * 0.6, 2, cv::LINE_AA);
  }
  add_noise(img, value_noise(rng, n, 32, 8.0));
  return img;
}

cv::Mat carpet(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, random_colour(rng, 60, 150));
  add_noise(img, value_noise(rng, n, 16, 18.0));
  speckle(rng, img, n * 4, 20, 230, 2);
  const int tiles = 4;
  for (int i = 0; i <= tiles; ++i) {
    cv::line(img, {i * n / tiles, 0}, {i * n / tiles, n}, cv::Scalar(30, 30, 30), 2);
    cv::line(img, {0, i * n / tiles}, {n, i * n / tiles}, cv::Scalar(30, 30, 30), 2);
  }
  return img;
}

cv::Mat ceiling(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, cv::Scalar(225, 225, 220));
  speckle(rng, img, n * 2, 150, 200, 1);
  const int tiles = 4;
  for (int i = 0; i <= tiles; ++i) {
    cv::line(img, {i * n / tiles, 0}, {i * n / tiles, n}, cv::Scalar(120, 120, 120), 3);
    cv::line(img, {0, i * n / tiles}, {n, i * n / tiles}, cv::Scalar(120, 120, 120), 3);
  }
  const int t = n / tiles;
  cv::rectangle(img, {t + 8, t + t / 3}, {2 * t - 8, 2 * t - t / 3}, cv::Scalar(255, 255, 240),
                cv::FILLED);
  cv::rectangle(img, {t + 8, t + t / 3}, {2 * t - 8, 2 * t - t / 3}, cv::Scalar(90, 90, 90), 2);
  return img;
}

cv::Mat fabric(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, random_colour(rng, 40, 200));
  const int cells = uniform_int(rng, 6, 12);
  const int c = n / cells;
  const cv::Scalar a = random_colour(rng, 0, 255);
  const cv::Scalar b = random_colour(rng, 0, 255);
  for (int r = 0; r < cells; ++r) {
    for (int k = 0; k < cells; ++k) {
      if ((r + k) % 2 == 0)
        cv::rectangle(img, {k * c, r * c}, {k * c + c - 1, r * c + c - 1}, a, cv::FILLED);
      cv::circle(img, {k * c + c / 2, r * c + c / 2}, c / 4, b, cv::FILLED, cv::LINE_AA);
    }
  }
  add_noise(img, value_noise(rng, n, 32, 10.0));
  return img;
}

cv::Mat shelf(Rng& rng, int n) {
  cv::Mat img(n, n, CV_8UC3, cv::Scalar(90, 70, 50));
  const int rows = 4;
  const int rh = n / rows;
  for (int r = 0; r < rows; ++r) {
    int x = 4;
    while (x < n - 8) {
      const int w = uniform_int(rng, 6, 28);
      const int h = uniform_int(rng, rh / 2, std::max(rh / 2, rh - 10));
      const cv::Scalar c = random_colour(rng, 20, 240);
      cv::rectangle(img, {x, r * rh + rh - 6 - h}, {std::min(n - 4, x + w), r * rh + rh - 6}, c,
                    cv::FILLED);
      cv::line(img, {x + 2, r * rh + rh - 6 - h / 2},
               {std::min(n - 4, x + w) - 2, r * rh + rh - 6 - h / 2}, c * 0.4, 2);
      x += w + uniform_int(rng, 0, 3);
    }
    cv::rectangle(img, {0, r * rh + rh - 6}, {n, r * rh + rh}, cv::Scalar(60, 45, 30), cv::FILLED);
  }
  return img;
}

}  // namespace

cv::Mat make_texture(TextureKind kind, int size, std::uint64_t seed) {
  if (size < 64) throw Error("texture size must be >= 64", {.field = "size"});
  Rng rng(seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(kind));
  switch (kind) {
    case TextureKind::kPlaster:
      return plaster(rng, size);
    case TextureKind::kBrick:
      return brick(rng, size);
    case TextureKind::kWood:
      return wood(rng, size);
    case TextureKind::kCarpet:
      return carpet(rng, size);
    case TextureKind::kCeiling:
      return ceiling(rng, size);
    case TextureKind::kFabric:
      return fabric(rng, size);
    case TextureKind::kShelf:
      return shelf(rng, size);
  }
  return plaster(rng, size);
}

int marker_bits(int dictionary) {
  return cv::aruco::getPredefinedDictionary(dictionary)->markerSize;
}

cv::Mat make_marker_texture(int dictionary, int id, int module_pixels, int margin_cells) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(dictionary);
  if (id < 0 || id >= dict->bytesList.rows) {
    throw Error("marker id " + std::to_string(id) + " is not in the dictionary", {.field = "id"});
  }
  const int cells = dict->markerSize + 2;
  cv::Mat code;
  dict->drawMarker(id, cells * module_pixels, code, 1);
  cv::Mat padded;
  const int pad = margin_cells * module_pixels;
  cv::copyMakeBorder(code, padded, pad, pad, pad, pad, cv::BORDER_CONSTANT, cv::Scalar(255));
  cv::Mat rgb;
  cv::cvtColor(padded, rgb, cv::COLOR_GRAY2RGB);
  return rgb;
}

}  // namespace coloc::registration::twin
