#include "registration/twin/sensor_noise.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "slam/core/error.hpp"

namespace coloc::registration::twin {

void DepthNoiseOptions::check() const {
  if (!(min_range >= 0.0 && max_range > min_range)) {
    throw Error("depth range must satisfy 0 <= min_range < max_range", {.field = "max_range"});
  }
  if (!(baseline > 0.0)) throw Error("baseline must be > 0", {.field = "baseline"});
  if (disparity_sigma < 0.0)
    throw Error("disparity_sigma must be >= 0", {.field = "disparity_sigma"});
  if (blob_dropout < 0.0 || blob_dropout > 0.5) {
    throw Error("blob_dropout must be in [0, 0.5]", {.field = "blob_dropout"});
  }
  if (correlated_fraction < 0.0 || correlated_fraction > 1.0) {
    throw Error("correlated_fraction must be in [0, 1]", {.field = "correlated_fraction"});
  }
}

namespace {

using Rng = std::mt19937_64;

// A smooth random field of unit variance over w x h pixels: independent normals every `cell`
// pixels, interpolated (stereo matching windows make D4xx noise spatially correlated).
cv::Mat smooth_field(Rng& rng, int w, int h, int cell, int interpolation) {
  std::normal_distribution<float> n01(0.0f, 1.0f);
  cv::Mat coarse(h / cell + 2, w / cell + 2, CV_32F);
  for (int r = 0; r < coarse.rows; ++r) {
    for (int c = 0; c < coarse.cols; ++c)
      coarse.at<float>(r, c) = n01(rng);
  }
  cv::Mat big;
  cv::resize(coarse, big, cv::Size(coarse.cols * cell, coarse.rows * cell), 0, 0, interpolation);
  cv::Mat field = big(cv::Rect(0, 0, w, h)).clone();
  // Interpolation lowers the variance (bilinear: to ~4/9); bring it back to one.
  cv::Scalar mean, stddev;
  cv::meanStdDev(field, mean, stddev);
  return (field - mean[0]) / std::max(1e-6, stddev[0]);
}

// Marks the top `fraction` quantile of a smooth field: blob-shaped holes.
void mark_blobs(Rng& rng, double fraction, cv::Mat& invalid) {
  const cv::Mat blob = smooth_field(rng, invalid.cols, invalid.rows, 16, cv::INTER_CUBIC);
  std::vector<float> values(blob.begin<float>(), blob.end<float>());
  const auto q =
      static_cast<std::size_t>((1.0 - fraction) * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(q), values.end());
  invalid.setTo(1, blob > values[q]);
}

// Range limits, edge dropouts, isolated dropouts and the occlusion shadow.
void mark_invalid(const cv::Mat& depth, double focal, const DepthNoiseOptions& o, Rng& rng,
                  cv::Mat& invalid) {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const int w = depth.cols, h = depth.rows;
  for (int v = 0; v < h; ++v) {
    const float* row = depth.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      const float z = row[u];
      if (!(z >= o.min_range && z <= o.max_range)) {
        invalid.at<std::uint8_t>(v, u) = 1;
        continue;
      }
      // Edges: a large relative jump to a 4-neighbour (or a neighbour with no depth).
      bool edge = false;
      const int nu[4] = {u - 1, u + 1, u, u};
      const int nv[4] = {v, v, v - 1, v + 1};
      for (int q = 0; q < 4 && !edge; ++q) {
        if (nu[q] < 0 || nv[q] < 0 || nu[q] >= w || nv[q] >= h) continue;
        const float zn = depth.at<float>(nv[q], nu[q]);
        edge = zn <= 0.0f || std::abs(zn - z) > o.edge_jump * z;
      }
      if ((edge && uni(rng) < o.edge_dropout) || uni(rng) < o.random_dropout) {
        invalid.at<std::uint8_t>(v, u) = 1;
      }
      // Occlusion shadow: the right imager cannot see background just left of a near object.
      if (o.shadow && u > 0) {
        const float zl = row[u - 1];
        if (zl > z * (1.0f + static_cast<float>(o.edge_jump))) {
          const int n = static_cast<int>(std::lround(focal * o.baseline * (1.0 / z - 1.0 / zl)));
          for (int b = 1; b <= n && u - b >= 0; ++b)
            invalid.at<std::uint8_t>(v, u - b) = 1;
        }
      }
    }
  }
}

}  // namespace

cv::Mat apply_depth_noise(const cv::Mat& depth, double focal, const DepthNoiseOptions& o,
                          std::uint64_t seed) {
  o.check();
  if (depth.type() != CV_32F) throw Error("depth must be CV_32F metres", {.field = "depth"});
  Rng rng(seed);
  std::normal_distribution<float> n01(0.0f, 1.0f);
  const int w = depth.cols, h = depth.rows;
  const cv::Mat smooth = smooth_field(rng, w, h, 8, cv::INTER_LINEAR);
  cv::Mat invalid(h, w, CV_8U, cv::Scalar(0));
  if (o.blob_dropout > 0.0) mark_blobs(rng, o.blob_dropout, invalid);
  mark_invalid(depth, focal, o, rng, invalid);

  // Stereo depth error: sigma_z = z^2 * sigma_disparity / (f * b).
  const double k = o.disparity_sigma / (focal * o.baseline);
  const float wc = static_cast<float>(std::sqrt(o.correlated_fraction));
  const float wi = static_cast<float>(std::sqrt(1.0 - o.correlated_fraction));
  cv::Mat out(h, w, CV_16U, cv::Scalar(0));
  for (int v = 0; v < h; ++v) {
    const float* row = depth.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      if (invalid.at<std::uint8_t>(v, u)) continue;
      const float z = row[u];
      const float sigma = static_cast<float>(k) * z * z;
      const float noisy = z + sigma * (wc * smooth.at<float>(v, u) + wi * n01(rng));
      const long mm = std::lround(noisy * 1000.0f);
      out.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::clamp(mm, 1L, 65535L));
    }
  }
  return out;
}

void add_image_noise(cv::Mat& rgb, double sigma, std::uint64_t seed) {
  if (sigma <= 0.0) return;
  cv::RNG rng(seed);
  cv::Mat noise(rgb.size(), CV_16SC3);
  rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(sigma));
  cv::Mat sum;
  rgb.convertTo(sum, CV_16SC3);
  sum += noise;
  sum.convertTo(rgb, CV_8UC3);
}

}  // namespace coloc::registration::twin
