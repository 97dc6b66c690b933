#pragma once
// Spatial distribution of corner candidates (ORB-SLAM's "octree", in fact a quadtree): the box
// holding the candidates is split into quadrants until there are as many non-empty cells as the
// quota, and each cell keeps its strongest candidate. Features thus cover the image evenly
// instead of piling up on the most textured region. Internal to the extractor; exposed for tests.

#include <vector>

namespace coloc::slam::features {

struct Candidate {
  float x = 0.0f;  // pixels in the level image
  float y = 0.0f;
  float response = 0.0f;
};

// Indices into `candidates` of at most `quota` selected candidates (every candidate must lie in
// [min_x, max_x) x [min_y, max_y)). Deterministic: ties are broken by index.
std::vector<int> distribute_quadtree(const std::vector<Candidate>& candidates, int quota,
                                     float min_x, float max_x, float min_y, float max_y);

}  // namespace coloc::slam::features
