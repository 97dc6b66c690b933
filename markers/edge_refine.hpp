#pragma once
// Corner refinement by edge-line fitting: the four sides of a marker's black border are located
// to sub-pixel precision at many points along each side (where the intensity profile across the
// side crosses the mid-level between the black border and the white margin), a line is fitted
// to each side by total least squares, and the corners are the intersections of adjacent lines.
// Using every pixel along the sides instead of a small window at each corner removes the bias of
// corner detectors at blurred square corners. Assumes straight sides (a pinhole image without
// distortion, such as a cube face); on distorted images use it only for small markers.

#include <array>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

namespace coloc::markers {

// Refines `quad` (4 corners, the detector's order) in an 8-bit grey image, for a marker of
// `cells` cells per side (data bits plus border). Returns false (and leaves `quad` unchanged)
// when a side has too few usable edge points or a corner would move by more than half a cell.
bool refine_corners_by_edges(const cv::Mat& grey, std::array<cv::Point2f, 4>& quad, int cells);

}  // namespace coloc::markers
