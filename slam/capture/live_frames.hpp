#pragma once
// A live camera as a dataset::FrameSource: `coloc map --camera` and `coloc localize --camera`
// read it exactly as they read a recorded sequence (colour BGR, depth in metres registered to
// the colour image). next() blocks for the next pair; nothing once the camera stopped.
#include "slam/capture/camera.hpp"
#include "slam/dataset/frame_source.hpp"

namespace coloc::capture {

class LiveFrames final : public dataset::FrameSource {
 public:
  explicit LiveFrames(RgbdCamera& camera) : camera_(camera) {}
  std::optional<dataset::Frame> next() override;

 private:
  RgbdCamera& camera_;
  std::size_t index_ = 0;
};

}  // namespace coloc::capture
