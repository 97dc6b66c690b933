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

cv::Mat apply_depth_noise(const cv::Mat& depth, double focal, const DepthNoiseOptions& o,
                          std::uint64_t seed) {
  o.check();
  CV_Assert(depth.type() == CV_32F);
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> n01(0.0f, 1.0f);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const int w = depth.cols, h = depth.rows;
  // Smooth part of the noise: a coarse unit-variance field, bilinearly upsampled (stereo
  // matching windows make D4xx noise spatially correlated).
  cv::Mat coarse(h / 8 + 2, w / 8 + 2, CV_32F);
  for (int r = 0; r < coarse.rows; ++r) {
    for (int c = 0; c < coarse.cols; ++c)
      coarse.at<float>(r, c) = n01(rng);
  }
  cv::Mat smooth;
  cv::resize(coarse, smooth, cv::Size(coarse.cols * 8, coarse.rows * 8), 0, 0, cv::INTER_LINEAR);
  // Interpolation lowers the variance (to ~4/9); bring the field back to unit variance.
  cv::Scalar mean, stddev;
  cv::meanStdDev(smooth, mean, stddev);
  smooth = (smooth - mean[0]) / std::max(1e-6, stddev[0]);
  const double k = o.disparity_sigma / (focal * o.baseline);
  const float wc = static_cast<float>(std::sqrt(o.correlated_fraction));
  const float wi = static_cast<float>(std::sqrt(1.0 - o.correlated_fraction));

  cv::Mat out(h, w, CV_16U, cv::Scalar(0));
  cv::Mat invalid(h, w, CV_8U, cv::Scalar(0));
  if (o.blob_dropout > 0.0) {
    // Blobs: the top `blob_dropout` quantile of a smooth random field (1/16 resolution).
    cv::Mat blob_coarse(h / 16 + 2, w / 16 + 2, CV_32F);
    for (int r = 0; r < blob_coarse.rows; ++r) {
      for (int c = 0; c < blob_coarse.cols; ++c)
        blob_coarse.at<float>(r, c) = n01(rng);
    }
    cv::Mat blob;
    cv::resize(blob_coarse, blob, cv::Size(blob_coarse.cols * 16, blob_coarse.rows * 16), 0, 0,
               cv::INTER_CUBIC);
    blob = blob(cv::Rect(0, 0, w, h)).clone();
    std::vector<float> values(blob.begin<float>(), blob.end<float>());
    const auto q = static_cast<std::size_t>((1.0 - o.blob_dropout) * (values.size() - 1));
    std::nth_element(values.begin(), values.begin() + static_cast<long>(q), values.end());
    invalid.setTo(1, blob > values[q]);
  }
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
          const double band = focal * o.baseline * (1.0 / z - 1.0 / zl);
          const int n = static_cast<int>(std::lround(band));
          for (int b = 1; b <= n && u - b >= 0; ++b)
            invalid.at<std::uint8_t>(v, u - b) = 1;
        }
      }
    }
  }
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
