#pragma once
// Bag-of-words representations of one image, as a Vocabulary produces them.

#include <cstdint>
#include <utility>
#include <vector>

namespace coloc::slam::bow {

using WordId = std::uint32_t;  // leaf of the vocabulary tree, 0 .. word_count() - 1
using NodeId = std::uint32_t;  // any node of the tree (0 is the root)

// Sparse TF-IDF weights of the words seen in an image, sorted by word, L1-normalised (the
// weights sum to 1 unless the image had no descriptor).
struct BowVector {
  struct Entry {
    WordId word;
    double weight;
  };
  std::vector<Entry> entries;

  bool empty() const { return entries.empty(); }
  std::size_t size() const { return entries.size(); }
};

// Direct index: for each tree node at the chosen level, the features (indices into the image's
// descriptor list, ascending) whose descriptor descends through it. Sorted by node. Matching
// only compares features that share a node.
struct FeatureVector {
  struct Entry {
    NodeId node;
    std::vector<std::uint32_t> features;
  };
  std::vector<Entry> entries;
  int level = 0;  // depth of the nodes below the root (1 = the root's children)
};

// L1 similarity (Nister & Stewenius; DBoW2's L1 score): 1 - |a - b|_1 / 2 for L1-normalised
// vectors, in [0, 1]: 1 for identical vectors, 0 for vectors without a common word. Exactly
// symmetric in a and b.
double score_l1(const BowVector& a, const BowVector& b);

}  // namespace coloc::slam::bow
