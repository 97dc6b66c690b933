#include "slam/tracking/image_features.hpp"

#include <opencv2/imgproc.hpp>

#include "slam/core/timing.hpp"

namespace coloc::slam::tracking {

cv::Mat to_grey(const cv::Mat& image, bool rgb) {
  cv::Mat grey = image;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, rgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
  if (image.channels() == 4)
    cv::cvtColor(image, grey, rgb ? cv::COLOR_RGBA2GRAY : cv::COLOR_BGRA2GRAY);
  return grey;
}

FeatureExtraction::FeatureExtraction(const features::ExtractorOptions& options,
                                     const Camera& camera, bool rgb_input)
    : extractor_(options), camera_(camera), rgb_input_(rgb_input) {}

ImageFeatures FeatureExtraction::operator()(const cv::Mat& image) {
  const Stopwatch watch;
  ImageFeatures out;
  out.grey = to_grey(image, rgb_input_);
  out.features = extractor_.extract(out.grey, &camera_);
  out.extract_ms = watch.elapsed_ms();
  return out;
}

}  // namespace coloc::slam::tracking
