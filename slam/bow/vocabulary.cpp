#include "slam/bow/vocabulary.hpp"

#include <algorithm>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::slam::bow {

void VocabularyOptions::check() const {
  auto bad = [](const char* field, const std::string& why) {
    throw Error("invalid vocabulary option: " + why, {.field = field});
  };
  if (branching < 2 || branching > 255) bad("branching", "must be in [2, 255]");
  if (depth < 1 || depth > 10) bad("depth", "must be in [1, 10]");
  if (max_iterations < 1) bad("max_iterations", "must be at least 1");
}

NodeId Vocabulary::descend(const Descriptor& d, int direct_level, NodeId* direct_node) const {
  NodeId node = 0;
  int level = 0;
  while (nodes_[node].child_count > 0) {
    const Node& parent = nodes_[node];
    NodeId best = parent.first_child;
    int best_distance = features::hamming_distance(d, nodes_[best].descriptor);
    for (NodeId c = parent.first_child + 1; c < parent.first_child + parent.child_count; ++c) {
      const int distance = features::hamming_distance(d, nodes_[c].descriptor);
      if (distance < best_distance) {
        best_distance = distance;
        best = c;
      }
    }
    node = best;
    ++level;
    if (direct_node != nullptr && level == direct_level) *direct_node = node;
  }
  // A branch that ended above the direct level (too few training descriptors) indexes by its leaf.
  if (direct_node != nullptr && level < direct_level) *direct_node = node;
  return node;
}

WordId Vocabulary::word_of(const Descriptor& descriptor) const {
  if (nodes_.empty()) throw Error("bag-of-words: the vocabulary is empty");
  return nodes_[descend(descriptor, 0, nullptr)].word;
}

BowVector Vocabulary::transform(const std::vector<Descriptor>& descriptors) const {
  BowVector bow;
  FeatureVector unused;
  transform(descriptors, bow, unused, 0);
  return bow;
}

void Vocabulary::transform(const std::vector<Descriptor>& descriptors, BowVector& bow,
                           FeatureVector& features, int direct_level) const {
  if (nodes_.empty()) throw Error("bag-of-words: the vocabulary is empty");
  bow.entries.clear();
  features.entries.clear();
  const bool with_direct = direct_level > 0;
  features.level = with_direct ? std::clamp(direct_level, 1, info_.depth) : 0;
  std::vector<std::pair<NodeId, std::uint32_t>> direct;
  if (with_direct) direct.reserve(descriptors.size());
  bow.entries.reserve(descriptors.size());
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    NodeId direct_node = 0;
    const WordId word =
        nodes_[descend(descriptors[i], features.level, with_direct ? &direct_node : nullptr)].word;
    // Each occurrence adds the word's idf: after normalisation this is tf * idf.
    bow.entries.push_back({word, word_weights_[word]});
    if (with_direct) direct.emplace_back(direct_node, static_cast<std::uint32_t>(i));
  }
  std::sort(bow.entries.begin(), bow.entries.end(),
            [](const BowVector::Entry& a, const BowVector::Entry& b) { return a.word < b.word; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < bow.entries.size(); ++i) {
    if (out > 0 && bow.entries[out - 1].word == bow.entries[i].word) {
      bow.entries[out - 1].weight += bow.entries[i].weight;
    } else {
      bow.entries[out++] = bow.entries[i];
    }
  }
  bow.entries.resize(out);
  // Room was reserved for one word per descriptor; a keyframe keeps its vector as long as the
  // map lives, and distinct words are typically a third fewer.
  bow.entries.shrink_to_fit();
  double norm = 0.0;
  for (const auto& e : bow.entries)
    norm += e.weight;
  if (norm > 0.0) {
    for (auto& e : bow.entries)
      e.weight /= norm;
  }

  if (!with_direct) return;
  std::sort(direct.begin(), direct.end());
  // Each node's features allocated at their exact count (a keyframe keeps them as long as the
  // map lives; grown one by one they held up to twice that).
  for (std::size_t first = 0; first < direct.size();) {
    std::size_t last = first + 1;
    while (last < direct.size() && direct[last].first == direct[first].first)
      ++last;
    FeatureVector::Entry& e = features.entries.emplace_back();
    e.node = direct[first].first;
    e.features.reserve(last - first);
    for (std::size_t i = first; i < last; ++i)
      e.features.push_back(direct[i].second);
    first = last;
  }
  features.entries.shrink_to_fit();
}

void Vocabulary::canonicalize() {
  std::vector<Node> ordered;
  ordered.reserve(nodes_.size());
  ordered.push_back(nodes_[0]);
  // Breadth-first: children of consecutive parents are appended consecutively, so first_child
  // follows from the child counts alone (which is what the file stores).
  for (std::size_t i = 0; i < ordered.size(); ++i) {
    Node& node = ordered[i];
    const NodeId old_first = node.first_child;
    node.first_child = node.child_count > 0 ? static_cast<NodeId>(ordered.size()) : 0;
    for (NodeId c = 0; c < node.child_count; ++c) {
      ordered.push_back(nodes_[old_first + c]);
    }
  }
  nodes_ = std::move(ordered);
  word_nodes_.clear();
  for (NodeId n = 0; n < nodes_.size(); ++n) {
    if (nodes_[n].child_count == 0) {
      nodes_[n].word = static_cast<WordId>(word_nodes_.size());
      word_nodes_.push_back(n);
    }
  }
  info_.node_count = static_cast<std::uint32_t>(nodes_.size());
  info_.word_count = static_cast<std::uint32_t>(word_nodes_.size());
}

}  // namespace coloc::slam::bow
