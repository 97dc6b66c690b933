// Vocabulary training: hierarchical k-means++ on binary descriptors with majority-bit centres.

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/error.hpp"

namespace coloc::slam::bow {
namespace {

// splitmix64: fixed definition, so a seed gives the same vocabulary with any standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  std::uint64_t below(std::uint64_t n) { return next() % n; }

 private:
  std::uint64_t state_;
};

// Index of the centre nearest to d (the lowest index on ties).
std::size_t nearest(const Descriptor& d, const std::vector<Descriptor>& centres) {
  std::size_t best = 0;
  int best_distance = features::hamming_distance(d, centres[0]);
  for (std::size_t c = 1; c < centres.size(); ++c) {
    const int distance = features::hamming_distance(d, centres[c]);
    if (distance < best_distance) {
      best_distance = distance;
      best = c;
    }
  }
  return best;
}

}  // namespace

// Builds the tree depth-first; owns the training state. Node ids are allocated in a fixed order
// and every node's random generator is seeded from (seed, node id), so the result depends only
// on the options and the data.
class VocabularyBuilder {
 public:
  VocabularyBuilder(const std::vector<Descriptor>& all, const VocabularyOptions& options,
                    const Vocabulary::ProgressFn& progress, Vocabulary& vocabulary)
      : all_(all), options_(options), progress_(progress), vocabulary_(vocabulary) {}

  void build(std::vector<std::uint32_t> members, NodeId node, int level) {
    std::vector<std::vector<std::uint32_t>> groups;
    if (level < options_.depth) groups = split(members, node);
    if (groups.size() < 2) {  // a word: depth reached, or nothing left to separate
      done_ += members.size();
      if (progress_) progress_(done_, all_.size());
      return;
    }
    members = {};  // the groups hold them now; keep memory bounded by the tree depth
    auto& nodes = vocabulary_.nodes_;
    const auto first = static_cast<NodeId>(nodes.size());
    nodes[node].first_child = first;
    nodes[node].child_count = static_cast<std::uint32_t>(groups.size());
    nodes.resize(nodes.size() + groups.size());
    for (std::size_t c = 0; c < groups.size(); ++c) {
      nodes[first + c].descriptor = majority(groups[c]);
    }
    for (std::size_t c = 0; c < groups.size(); ++c) {
      build(std::move(groups[c]), first + static_cast<NodeId>(c), level + 1);
    }
  }

 private:
  // Per-bit majority of a set of descriptors (bit set when more than half the members have it).
  Descriptor majority(const std::vector<std::uint32_t>& members) const {
    std::vector<std::uint32_t> counts(256, 0);
    for (std::uint32_t m : members) {
      const Descriptor& d = all_[m];
      for (int w = 0; w < 4; ++w) {
        const std::uint64_t bits = d[static_cast<std::size_t>(w)];
        std::uint32_t* c = &counts[static_cast<std::size_t>(w * 64)];
        for (int j = 0; j < 64; ++j)
          c[j] += static_cast<std::uint32_t>((bits >> j) & 1U);
      }
    }
    Descriptor out{};
    for (int i = 0; i < 256; ++i) {
      if (2 * static_cast<std::uint64_t>(counts[static_cast<std::size_t>(i)]) > members.size()) {
        out[static_cast<std::size_t>(i >> 6)] |= std::uint64_t{1} << (i & 63);
      }
    }
    return out;
  }

  // k-means++ seeding (Arthur & Vassilvitskii): each new centre drawn with probability
  // proportional to the squared distance to the nearest centre chosen so far.
  std::vector<Descriptor> seed_centres(const std::vector<std::uint32_t>& members, Random& random) {
    const std::size_t k = static_cast<std::size_t>(options_.branching);
    std::vector<Descriptor> centres{all_[members[random.below(members.size())]]};
    std::vector<std::uint32_t> distance(members.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
      distance[i] =
          static_cast<std::uint32_t>(features::hamming_distance(all_[members[i]], centres[0]));
    }
    while (centres.size() < k) {
      std::uint64_t total = 0;
      for (std::uint32_t d : distance)
        total += static_cast<std::uint64_t>(d) * d;
      if (total == 0) break;  // every member equals a centre already
      std::uint64_t target = random.below(total);
      std::size_t pick = 0;
      for (; pick + 1 < members.size(); ++pick) {
        const std::uint64_t w = static_cast<std::uint64_t>(distance[pick]) * distance[pick];
        if (target < w) break;
        target -= w;
      }
      centres.push_back(all_[members[pick]]);
      for (std::size_t i = 0; i < members.size(); ++i) {
        const auto d = static_cast<std::uint32_t>(
            features::hamming_distance(all_[members[i]], centres.back()));
        distance[i] = std::min(distance[i], d);
      }
    }
    return centres;
  }

  // Splits the members of `node` into at most `branching` non-empty clusters.
  std::vector<std::vector<std::uint32_t>> split(const std::vector<std::uint32_t>& members,
                                                NodeId node) {
    if (members.size() < 2) return {};
    Random random(options_.seed ^ (0x9e3779b97f4a7c15ULL * (static_cast<std::uint64_t>(node) + 1)));
    std::vector<Descriptor> centres = seed_centres(members, random);
    std::vector<std::uint32_t> label(members.size(), 0);
    for (int iteration = 0; iteration < options_.max_iterations; ++iteration) {
      bool changed = iteration == 0;
      for (std::size_t i = 0; i < members.size(); ++i) {
        const auto c = static_cast<std::uint32_t>(nearest(all_[members[i]], centres));
        changed = changed || c != label[i];
        label[i] = c;
      }
      if (!changed) break;
      std::vector<std::vector<std::uint32_t>> groups(centres.size());
      for (std::size_t i = 0; i < members.size(); ++i)
        groups[label[i]].push_back(members[i]);
      for (std::size_t c = 0; c < centres.size(); ++c) {
        if (!groups[c].empty())
          centres[c] = majority(groups[c]);  // an empty cluster keeps its centre
      }
    }
    std::vector<std::vector<std::uint32_t>> groups(centres.size());
    for (std::size_t i = 0; i < members.size(); ++i)
      groups[label[i]].push_back(members[i]);
    std::erase_if(groups, [](const auto& g) { return g.empty(); });
    return groups;
  }

  const std::vector<Descriptor>& all_;
  const VocabularyOptions& options_;
  const Vocabulary::ProgressFn& progress_;
  Vocabulary& vocabulary_;
  std::uint64_t done_ = 0;
};

Vocabulary Vocabulary::train(const std::vector<std::vector<Descriptor>>& images,
                             const VocabularyOptions& options, const ProgressFn& progress) {
  options.check();
  std::vector<Descriptor> all;
  for (const auto& image : images)
    all.insert(all.end(), image.begin(), image.end());
  if (all.empty()) throw Error("vocabulary training: no descriptors given", {.field = "images"});
  if (all.size() > 0xffffffffULL) {
    throw Error("vocabulary training: more than 2^32 descriptors", {.field = "images"});
  }

  Vocabulary vocabulary;
  vocabulary.info_.branching = options.branching;
  vocabulary.info_.depth = options.depth;
  vocabulary.info_.seed = options.seed;
  vocabulary.info_.training_images = static_cast<std::uint32_t>(images.size());
  vocabulary.info_.training_descriptors = all.size();
  vocabulary.nodes_.resize(1);
  std::vector<std::uint32_t> members(all.size());
  for (std::size_t i = 0; i < all.size(); ++i)
    members[i] = static_cast<std::uint32_t>(i);
  VocabularyBuilder builder(all, options, progress, vocabulary);
  builder.build(std::move(members), 0, 0);
  vocabulary.canonicalize();

  // IDF: log(N / n_i) with n_i the number of training images in which word i occurs, using the
  // same greedy descent as transform() so training and use agree.
  std::vector<std::uint32_t> images_with_word(vocabulary.word_count(), 0);
  std::vector<std::uint32_t> last_image(vocabulary.word_count(), 0xffffffffU);
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (const Descriptor& d : images[i]) {
      const WordId w = vocabulary.word_of(d);
      if (last_image[w] != i) {
        last_image[w] = static_cast<std::uint32_t>(i);
        ++images_with_word[w];
      }
    }
  }
  vocabulary.word_weights_.resize(vocabulary.word_count());
  const auto n_images = static_cast<double>(images.size());
  for (std::size_t w = 0; w < images_with_word.size(); ++w) {
    // A word no training image reaches by descent still gets the largest weight, not infinity.
    const double n = std::max<double>(images_with_word[w], 1.0);
    // Rounded to float, as the file stores it, so a saved and reloaded vocabulary is identical.
    vocabulary.word_weights_[w] = static_cast<float>(std::log(n_images / n));
  }
  return vocabulary;
}

}  // namespace coloc::slam::bow
