#pragma once
// A frame source's frames with their ORB features extracted on a thread of their own, while
// tracking works on the frames before: extraction is about half of a frame's tracking time, and
// the second core is idle whenever tracking waits for local mapping (a sequential replay) or
// the mapper is idle (live). Frames keep their order; the map is the same as with tracking
// extracting itself (tracking::FeatureExtraction gives identical features).
#include <cstddef>
#include <optional>

#include "slam/core/prefetch.hpp"
#include "slam/dataset/frame_source.hpp"
#include "slam/tracking/image_features.hpp"

namespace coloc::slam::pipeline {

struct ExtractedFrame {
  dataset::Frame frame;  // colour in the camera's channel order
  // None when extraction failed on this image: tracking then extracts itself and names what
  // is wrong with the image, as without this stage.
  std::optional<tracking::ImageFeatures> features;
};

class ExtractAhead {
 public:
  // `source` must outlive this. `capacity`: frames extracted and not yet taken. A recording
  // wants several (tracking waiting for a local BA takes them in a burst afterwards); a live
  // camera one, so that a tracker slower than the camera works on recent frames rather than a
  // backlog. `rgb_order`: the settings' Camera.RGB (dataset::to_camera_order).
  ExtractAhead(dataset::FrameSource& source, tracking::FeatureExtraction extraction, bool rgb_order,
               std::size_t capacity);

  // The next frame; nothing at the end. An exception of the source comes out here, at its frame.
  std::optional<ExtractedFrame> next() { return worker_.next(); }

 private:
  std::optional<ExtractedFrame> extract_next();  // on the worker thread

  dataset::FrameSource& source_;
  tracking::FeatureExtraction extraction_;
  bool rgb_order_;
  Prefetch<ExtractedFrame> worker_;  // last: its thread uses the members above
};

}  // namespace coloc::slam::pipeline
