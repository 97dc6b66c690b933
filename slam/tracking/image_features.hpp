#pragma once
// What tracking computes from a frame's image alone, before it reads the map: the grey image
// and its ORB features. It is half of a frame's tracking time (6.7 of 12 ms median on fr1/rpy),
// so a caller with a spare core extracts the next frames on another thread while tracking works
// on this one (slam/pipeline/extract_ahead.hpp) and hands the result to Tracker::track().
#include <opencv2/core/mat.hpp>

#include "slam/core/camera.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::slam::tracking {

// The grey image tracking works on: 8-bit grey as it is, 3- or 4-channel colour converted with the
// channel weights of its order (`rgb`: RGB(A), else BGR(A)).
cv::Mat to_grey(const cv::Mat& image, bool rgb);

struct ImageFeatures {
  cv::Mat grey;
  features::OrbFeatures features;  // keypoints undistorted with the camera
  double extract_ms = 0.0;         // wall time of the extraction, on the thread that ran it
};

// The extraction Tracker::track() runs, given the same options, camera and colour order: the
// features are identical, so a map does not depend on which thread extracted them. Not
// thread-safe (the extractor keeps its pyramid between calls): one instance per thread.
class FeatureExtraction {
 public:
  FeatureExtraction(const features::ExtractorOptions& options, const Camera& camera,
                    bool rgb_input);
  // `image`: as Tracker::track() takes it. OpenCV's exceptions pass through for images no
  // camera gives (Tracker::track() checks the image first and names what is wrong).
  ImageFeatures operator()(const cv::Mat& image);

 private:
  features::OrbExtractor extractor_;
  Camera camera_;
  bool rgb_input_;
};

}  // namespace coloc::slam::tracking
