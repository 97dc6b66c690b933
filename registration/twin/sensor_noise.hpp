#pragma once
// Sensor models for the twin's RGB-D frames: a RealSense D455-like depth error (stereo depth
// noise growing with the square of depth, occlusion shadows and dropouts at depth edges, range
// limits, 1 mm quantization) and colour-image noise. Deterministic in the seed.

#include <cstdint>
#include <opencv2/core.hpp>

namespace coloc::registration::twin {

struct DepthNoiseOptions {
  double min_range = 0.4;            // metres; nearer is invalid (0)
  double max_range = 6.0;            // metres; farther is invalid (0)
  double baseline = 0.095;           // metres (D455 stereo baseline)
  double disparity_sigma = 0.08;     // pixels of subpixel disparity noise: sigma_z = z^2 s / (f b)
  double correlated_fraction = 0.6;  // share of the variance in a smooth 8x8-pixel noise field
  double edge_jump = 0.04;           // relative depth jump that counts as an edge
  double edge_dropout = 0.5;         // probability that a pixel at an edge is invalid
  double random_dropout = 0.002;     // probability of an isolated invalid pixel
  double blob_dropout = 0.015;       // fraction of the image lost in smooth blobs (IR-dark spots)
  bool shadow = true;                // invalidate the occlusion shadow left of near objects

  void check() const;
};

// depth: CV_32F metres (0 = nothing); focal: pixels. Returns CV_16U in millimetres (0 =
// invalid), as the RealSense writes it.
cv::Mat apply_depth_noise(const cv::Mat& depth, double focal, const DepthNoiseOptions& options,
                          std::uint64_t seed);

// Adds Gaussian noise (sigma in 8-bit units) to a CV_8UC3 image, in place.
void add_image_noise(cv::Mat& rgb, double sigma, std::uint64_t seed);

}  // namespace coloc::registration::twin
