#pragma once
// ORB features as ORB-SLAM extracts them, written for coloc:
//   1. an image pyramid of `n_levels` levels, each `scale_factor` smaller than the one before;
//   2. FAST corners per grid cell (~30 px) of each level, with threshold `ini_th_fast`, falling
//      back to `min_th_fast` in cells where the first finds nothing (so low-contrast regions
//      still get features);
//   3. a quadtree per level that keeps the strongest corner of each cell until the level's
//      quota (a geometric share of `n_features`) is met, spreading features over the image;
//   4. orientation by intensity centroid (radius 15 px) on the level image;
//   5. a steered 256-bit BRIEF descriptor on the Gaussian-smoothed level (7x7, sigma 2);
//   6. keypoints undistorted with the camera model (coloc::undistort_pixel), if one is given.
// Extraction is deterministic: the same image and options give the same features, bit for bit.
//
// Coordinates: pixels of the level-0 (input) image, origin at the centre of the top-left pixel,
// x right, y down. Angles in radians, [0, 2 pi), measured from +x towards +y.

#include <opencv2/core/mat.hpp>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/features/brief_pattern.hpp"
#include "slam/features/descriptor.hpp"

namespace coloc::slam::features {

// The ORBextractor.* settings of ORB-SLAM's camera files map one to one onto these fields.
struct ExtractorOptions {
  int n_features = 1000;      // ORBextractor.nFeatures: total over all levels
  double scale_factor = 1.2;  // ORBextractor.scaleFactor: > 1
  int n_levels = 8;           // ORBextractor.nLevels: 1..32
  int ini_th_fast = 20;       // ORBextractor.iniThFAST: intensity difference, 1..255
  int min_th_fast = 7;        // ORBextractor.minThFAST: 1..ini_th_fast

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct Keypoint {
  float x = 0.0f;  // level-0 pixel as detected (distorted image)
  float y = 0.0f;
  float ux = 0.0f;        // undistorted pixel (ideal pinhole with the camera's fx fy cx cy);
  float uy = 0.0f;        // equal to x, y when no camera or no distortion
  float angle = 0.0f;     // radians, [0, 2 pi)
  float response = 0.0f;  // FAST score (largest threshold at which it is still a corner)
  int level = 0;          // pyramid level it was detected on
};

// The features of one image: keypoints[i] has descriptors[i].
struct OrbFeatures {
  std::vector<Keypoint> keypoints;
  std::vector<Descriptor> descriptors;
  int image_width = 0;
  int image_height = 0;

  std::size_t size() const { return keypoints.size(); }
};

// Not thread-safe (it reuses its pyramid buffers between calls): use one extractor per thread.
class OrbExtractor {
 public:
  explicit OrbExtractor(ExtractorOptions options = {});

  // `image`: CV_8UC1 grey, or CV_8UC3 BGR (converted to grey). Throws coloc::Error for other
  // types or an empty image. `camera` (may be null) undistorts the keypoints; it should describe
  // the image's resolution.
  OrbFeatures extract(const cv::Mat& image, const Camera* camera = nullptr);

  const ExtractorOptions& options() const { return options_; }
  // Scale of level l relative to level 0 (scale_factor^l), its square, and the per-level quota.
  const std::vector<float>& scale_factors() const { return scales_; }
  const std::vector<float>& level_sigma2() const { return sigma2_; }
  const std::vector<int>& features_per_level() const { return quota_; }

  // Keypoints never come closer than this to the border of their level image (pixels).
  static constexpr int kBorder = 16;
  // Radius of the orientation patch (pixels, at the keypoint's level).
  static constexpr int kOrientationRadius = 15;

 private:
  void build_pyramid(const cv::Mat& grey);
  void detect_level(int level, std::vector<Keypoint>& out);
  void describe_level(int level, const std::vector<Keypoint>& keypoints, std::size_t first,
                      std::vector<Descriptor>& out);

  ExtractorOptions options_;
  BriefPattern pattern_;
  std::vector<float> scales_;
  std::vector<float> sigma2_;
  std::vector<int> quota_;
  std::vector<int> umax_;  // half-width of the orientation disc per row offset
  std::vector<cv::Mat> levels_;
  std::vector<cv::Mat> smoothed_;
};

// Fraction of the cells of a cols x rows grid over the image that hold at least one keypoint
// (level-0 detected pixel): the coverage figure of `coloc bench orb`.
double grid_coverage(const std::vector<Keypoint>& keypoints, int image_width, int image_height,
                     int cols = 16, int rows = 12);

}  // namespace coloc::slam::features
