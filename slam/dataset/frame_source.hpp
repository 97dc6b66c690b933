#pragma once
// Frames one after the other, from a recorded sequence or from a live camera (slam/capture's
// LiveFrames): what `coloc map` and `coloc localize` consume. Same conventions as Frame
// (colour BGR, depth CV_32FC1 metres, timestamps in seconds).
#include <memory>
#include <optional>

#include "slam/dataset/sequence.hpp"

namespace coloc::dataset {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next frame; nothing at the end (of the sequence, or when the camera stopped).
  virtual std::optional<Frame> next() = 0;
  // Frames still to come when known (a sequence), 0 when not (a live camera).
  virtual std::size_t remaining() const { return 0; }
  // Frames that could not be read and were skipped (each named in a warning).
  virtual std::size_t skipped() const { return 0; }
};

// The frames of `sequence` in order; an unreadable frame is skipped with a warning and counted
// (one bad image must not cost a session). The sequence must outlive the source.
std::unique_ptr<FrameSource> frames_of(const Sequence& sequence);

// Frames of `source` handed out as a live camera delivers them: frame i no earlier than
// (t_i - t_0) seconds after the first was handed out, never dropped (a consumer slower than the
// camera falls behind, as ORB-SLAM2's rgbd_tum does). What the consumer does with the wait (the
// mapper's thread gets it) is what separates a paced run from an unpaced one.
std::unique_ptr<FrameSource> paced(std::unique_ptr<FrameSource> source);

}  // namespace coloc::dataset
