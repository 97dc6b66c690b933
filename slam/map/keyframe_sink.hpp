#pragma once
// Where tracking hands each new keyframe after inserting it into the map: local mapping in a
// SLAM system, nothing in localization-only (a tracker without a sink never makes keyframes),
// and, behind local mapping's own output, a loop closer. Tracking depends on this interface only,
// so the tracker builds and runs without the mapper, and stages can be chained.
//
// Thread-safety: implementations are called from the producer's thread while they process
// keyframes in their own; every member must be safe to call concurrently with that work.
#include <cstddef>
#include <opencv2/core/mat.hpp>

#include "slam/core/ids.hpp"

namespace coloc::slam::map {

struct KeyframeMessage {
  KeyframeId id;  // already in the map
  cv::Mat grey;   // the keyframe's image, for marker detection (may be empty)
};

class KeyframeSink {
 public:
  virtual ~KeyframeSink() = default;
  // Hands a keyframe on; blocks while the sink is full. False when the sink was closed (the
  // keyframe stays in the map, unprocessed).
  virtual bool push(KeyframeMessage message) = 0;
  // Nothing queued or being processed (ORB-SLAM's AcceptKeyFrames): tracking may then insert
  // keyframes more eagerly.
  virtual bool idle() const = 0;
  // Keyframes waiting to be processed.
  virtual std::size_t queued() const = 0;
  // False while the sink does not take keyframes (paused for a loop correction): tracking then
  // makes none.
  virtual bool accepting() const = 0;
  // A keyframe is coming: cut a long optional computation (local BA) short.
  virtual void interrupt() = 0;
  // Blocks until idle (the deterministic sequential mode of tests and benchmarks), or until the
  // sink stops.
  virtual void wait_idle() = 0;
};

}  // namespace coloc::slam::map
