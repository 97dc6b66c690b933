#pragma once
// Our bag-of-words vocabulary for binary (ORB) descriptors: a tree built by hierarchical
// k-means++ (Nister & Stewenius; Galvez-Lopez & Tardos' DBoW2 for binary words) with `branching`
// children per node and `depth` levels; cluster centres of binary descriptors are the
// per-bit majority of their members. Leaves are the words, weighted by inverse document
// frequency over the training images; images become TF-IDF vectors compared by the L1 score.
//
// File format (little-endian), see vocabulary_io.cpp:
//   "COLOCVOC" | u32 version | u32 branching, depth, descriptor bits, weighting, scoring |
//   u32 training images | u64 training descriptors | u64 seed | u32 node count, word count |
//   nodes in breadth-first order: u8 child count + 32-byte descriptor |
//   words (the leaves in node order): f32 idf weight | u64 FNV-1a checksum of all bytes before.
//
// Thread-safety: a Vocabulary is immutable after training or loading; const methods may be
// called from any number of threads.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "slam/bow/bow_vector.hpp"
#include "slam/features/descriptor.hpp"

namespace coloc::slam::bow {

using features::Descriptor;

struct VocabularyOptions {
  int branching = 10;       // k: children per node, 2..255
  int depth = 5;            // L: levels below the root, 1..10 (k^L words at most)
  int max_iterations = 10;  // k-means iterations per node (stops earlier when stable)
  std::uint64_t seed = 1;   // k-means++ seeding; same seed + same data => same vocabulary

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// What the header of a vocabulary file says.
struct VocabularyInfo {
  int branching = 0;
  int depth = 0;
  std::uint32_t node_count = 0;
  std::uint32_t word_count = 0;
  std::uint32_t training_images = 0;
  std::uint64_t training_descriptors = 0;
  std::uint64_t seed = 0;
};

class Vocabulary {
 public:
  // Progress callback of training: (descriptors placed in leaves so far, total descriptors).
  using ProgressFn = std::function<void(std::uint64_t done, std::uint64_t total)>;

  // Trains on the descriptors of a set of images (one inner vector per image; the image split
  // matters for the IDF weights). Throws coloc::Error for bad options or no descriptors.
  static Vocabulary train(const std::vector<std::vector<Descriptor>>& images,
                          const VocabularyOptions& options, const ProgressFn& progress = {});

  // Binary file IO. load() throws coloc::Error naming the file (and byte offset) for a missing,
  // truncated, damaged (checksum) or foreign file, or an unsupported version.
  void save(const std::filesystem::path& path) const;
  static Vocabulary load(const std::filesystem::path& path);
  // The same format in memory (save() writes exactly these bytes).
  std::vector<std::uint8_t> serialize() const;
  static Vocabulary deserialize(const std::vector<std::uint8_t>& bytes,
                                const std::filesystem::path& source = {});

  // The word a descriptor falls into (greedy descent: nearest child by Hamming distance).
  WordId word_of(const Descriptor& descriptor) const;
  // TF-IDF vector of an image's descriptors.
  BowVector transform(const std::vector<Descriptor>& descriptors) const;
  // Same, plus the direct index at `direct_level` below the root (clamped to [1, depth]; 0 or
  // less leaves `features` empty). ORB-SLAM uses 4 levels above the leaves of its 6-level tree,
  // i.e. level 2, which is also what suits our 5-level vocabulary (about 100 nodes).
  void transform(const std::vector<Descriptor>& descriptors, BowVector& bow,
                 FeatureVector& features, int direct_level = 2) const;

  double idf(WordId word) const { return word_weights_[word]; }
  std::uint32_t word_count() const { return static_cast<std::uint32_t>(word_nodes_.size()); }
  std::uint32_t node_count() const { return static_cast<std::uint32_t>(nodes_.size()); }
  const VocabularyInfo& info() const { return info_; }
  bool empty() const { return nodes_.empty(); }

 private:
  friend class VocabularyBuilder;
  struct Node {
    Descriptor descriptor{};
    std::uint32_t first_child = 0;
    std::uint32_t child_count = 0;  // 0 for a word
    WordId word = 0;                // valid when child_count == 0
  };
  // Descends from the root; `direct_node` receives the node at `direct_level`.
  NodeId descend(const Descriptor& d, int direct_level, NodeId* direct_node) const;
  // Renumbers nodes breadth-first and words in node order (the canonical, saved layout).
  void canonicalize();

  std::vector<Node> nodes_;           // nodes_[0] is the root
  std::vector<NodeId> word_nodes_;    // node of each word
  std::vector<double> word_weights_;  // idf of each word
  VocabularyInfo info_;
};

}  // namespace coloc::slam::bow
