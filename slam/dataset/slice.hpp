#pragma once
// A contiguous range of another sequence's frames (`coloc map --frames A:B`): mapping the first
// half of a walk, then continuing the saved map with the second half. Ground truth, IMU and
// camera are the whole sequence's (the ATE then compares the frames the slice has).
#include <cstddef>
#include <memory>
#include <string>

#include "slam/dataset/sequence.hpp"

namespace coloc::dataset {

// Frames [first, last) of `sequence` (last clamped to its size). Throws coloc::Error naming the
// sequence when the range is empty.
std::unique_ptr<Sequence> slice(std::unique_ptr<Sequence> sequence, std::size_t first,
                                std::size_t last);

// "A:B", "A:" (to the end) or ":B" -> [A, B). Throws coloc::Error naming `what` otherwise.
std::pair<std::size_t, std::size_t> parse_frame_range(const std::string& text,
                                                      const std::string& what);

}  // namespace coloc::dataset
