#include "slam/features/quadtree.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace coloc::slam::features {
namespace {

// A cell of the tree: a box and the range [begin, end) of `order` holding its candidates.
struct Node {
  float x0, y0, x1, y1;
  int begin, end;
  int count() const { return end - begin; }
  // A cell at most a pixel wide and high holds at most one integer position: splitting further
  // would only separate candidates at the same place.
  bool splittable() const { return count() > 1 && ((x1 - x0) > 1.0f || (y1 - y0) > 1.0f); }
};

class QuadTree {
 public:
  explicit QuadTree(const std::vector<Candidate>& candidates)
      : candidates_(candidates), scratch_(candidates.size()) {}

  std::vector<int> order;
  std::vector<Node> nodes;

  // Replaces nodes[i] by its non-empty quadrants (first in place, the others appended).
  void split(std::size_t i) {
    const Node parent = nodes[i];
    const float mx = 0.5f * (parent.x0 + parent.x1);
    const float my = 0.5f * (parent.y0 + parent.y1);
    int counts[4] = {0, 0, 0, 0};
    auto quadrant = [&](int idx) {
      const Candidate& c = candidates_[static_cast<std::size_t>(idx)];
      return (c.x >= mx ? 1 : 0) + (c.y >= my ? 2 : 0);
    };
    for (int k = parent.begin; k < parent.end; ++k)
      ++counts[quadrant(order[k])];
    int starts[4];
    int pos = parent.begin;
    for (int q = 0; q < 4; ++q) {
      starts[q] = pos;
      pos += counts[q];
    }
    int fill[4] = {starts[0], starts[1], starts[2], starts[3]};
    for (int k = parent.begin; k < parent.end; ++k) {
      scratch_[static_cast<std::size_t>(fill[quadrant(order[k])]++)] = order[k];
    }
    std::copy(scratch_.begin() + parent.begin, scratch_.begin() + parent.end,
              order.begin() + parent.begin);
    bool first = true;
    for (int q = 0; q < 4; ++q) {
      if (counts[q] == 0) continue;
      const Node child{(q & 1) ? mx : parent.x0,
                       (q & 2) ? my : parent.y0,
                       (q & 1) ? parent.x1 : mx,
                       (q & 2) ? parent.y1 : my,
                       starts[q],
                       starts[q] + counts[q]};
      if (first) {
        nodes[i] = child;
        first = false;
      } else {
        nodes.push_back(child);
      }
    }
  }

 private:
  const std::vector<Candidate>& candidates_;
  std::vector<int> scratch_;
};

// Index of the strongest candidate of a node (lowest index on ties).
int best_of(const std::vector<Candidate>& candidates, const std::vector<int>& order,
            const Node& node) {
  int best = order[static_cast<std::size_t>(node.begin)];
  for (int k = node.begin + 1; k < node.end; ++k) {
    const int idx = order[static_cast<std::size_t>(k)];
    const float r = candidates[static_cast<std::size_t>(idx)].response;
    const float rb = candidates[static_cast<std::size_t>(best)].response;
    if (r > rb || (r == rb && idx < best)) best = idx;
  }
  return best;
}

}  // namespace

std::vector<int> distribute_quadtree(const std::vector<Candidate>& candidates, int quota,
                                     float min_x, float max_x, float min_y, float max_y) {
  if (candidates.empty() || quota <= 0) return {};
  QuadTree tree(candidates);
  tree.order.resize(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i)
    tree.order[i] = static_cast<int>(i);

  // Start from roughly square cells (one column per image height of width), as ORB-SLAM does.
  const float width = max_x - min_x;
  const float height = max_y - min_y;
  const int columns = std::max(1, static_cast<int>(std::lround(width / std::max(height, 1.0f))));
  tree.nodes.push_back({min_x, min_y, max_x, max_y, 0, static_cast<int>(candidates.size())});
  if (columns > 1) {
    // Stable bucketing of candidates into columns.
    std::vector<std::vector<int>> buckets(static_cast<std::size_t>(columns));
    for (int idx : tree.order) {
      const float u = (candidates[static_cast<std::size_t>(idx)].x - min_x) / width;
      const int c = std::clamp(static_cast<int>(u * static_cast<float>(columns)), 0, columns - 1);
      buckets[static_cast<std::size_t>(c)].push_back(idx);
    }
    tree.nodes.clear();
    int pos = 0;
    for (int c = 0; c < columns; ++c) {
      const auto& bucket = buckets[static_cast<std::size_t>(c)];
      std::copy(bucket.begin(), bucket.end(), tree.order.begin() + pos);
      const float x0 = min_x + width * static_cast<float>(c) / static_cast<float>(columns);
      const float x1 = min_x + width * static_cast<float>(c + 1) / static_cast<float>(columns);
      if (!bucket.empty()) {
        tree.nodes.push_back({x0, min_y, x1, max_y, pos, pos + static_cast<int>(bucket.size())});
      }
      pos += static_cast<int>(bucket.size());
    }
  }

  const std::size_t target = static_cast<std::size_t>(quota);
  std::vector<std::size_t> splittable;
  while (tree.nodes.size() < target) {
    splittable.clear();
    for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
      if (tree.nodes[i].splittable()) splittable.push_back(i);
    }
    if (splittable.empty()) break;
    if (tree.nodes.size() + 3 * splittable.size() < target) {
      // Far from the quota: split every cell, which keeps cells of one depth the same size.
      for (std::size_t i : splittable)
        tree.split(i);
      continue;
    }
    // Near the quota: split the most crowded cells first and stop once it is reached.
    std::stable_sort(splittable.begin(), splittable.end(), [&](std::size_t a, std::size_t b) {
      return tree.nodes[a].count() > tree.nodes[b].count();
    });
    for (std::size_t i : splittable) {
      tree.split(i);
      if (tree.nodes.size() >= target) break;
    }
  }

  std::vector<int> selected;
  selected.reserve(tree.nodes.size());
  for (const Node& node : tree.nodes)
    selected.push_back(best_of(candidates, tree.order, node));
  if (selected.size() > target) {
    // A last split can overshoot by up to three cells: drop the weakest.
    std::sort(selected.begin(), selected.end(), [&](int a, int b) {
      const float ra = candidates[static_cast<std::size_t>(a)].response;
      const float rb = candidates[static_cast<std::size_t>(b)].response;
      return ra > rb || (ra == rb && a < b);
    });
    selected.resize(target);
  }
  std::sort(selected.begin(), selected.end());
  return selected;
}

}  // namespace coloc::slam::features
