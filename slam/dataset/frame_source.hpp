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
  // Frames handed out a frame interval or more after their time (paced sources only): a live
  // camera, which keeps only its newest frame, would have dropped at least one frame each time.
  virtual std::size_t late() const { return 0; }
};

// The frames of `sequence` in order; an unreadable frame is skipped with a warning and counted
// (one bad image must not cost a session). The sequence must outlive the source.
std::unique_ptr<FrameSource> frames_of(const Sequence& sequence);

// Frames of `source` handed out as a live camera delivers them: frame i no earlier than
// (t_i - t_0) seconds after the first was handed out, never dropped (a consumer slower than the
// camera falls behind, as ORB-SLAM2's rgbd_tum does). What the consumer does with the wait (the
// mapper's thread gets it) is what separates a paced run from an unpaced one. Frames asked for
// a frame interval (the gap to the frame before) or more after their time are counted (late()).
std::unique_ptr<FrameSource> paced(std::unique_ptr<FrameSource> source);

// The frames of `source`, read on a thread of their own up to `capacity` frames ahead: the same
// frames in the same order, decoded while the consumer tracks. A replay's PNG/JPEG decoding is
// then off the tracking thread; sequentially mapped, it overlaps the local BA that tracking
// waits for. An exception of `source` comes out of next() where its frame would have been.
// For recordings: the destructor waits for a read in progress, which a live camera's next()
// could hold indefinitely.
std::unique_ptr<FrameSource> read_ahead(std::unique_ptr<FrameSource> source,
                                        std::size_t capacity = 8);

}  // namespace coloc::dataset
