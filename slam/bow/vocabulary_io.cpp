// The binary vocabulary file (layout in vocabulary.hpp). Everything is little-endian and read
// byte by byte, so files move between machines; the checksum catches damaged copies.

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::slam::bow {
namespace {

constexpr char kMagic[8] = {'C', 'O', 'L', 'O', 'C', 'V', 'O', 'C'};
constexpr std::uint32_t kVersion = 1;
constexpr std::uint32_t kDescriptorBits = 256;
constexpr std::uint32_t kWeightingTfIdf = 1;
constexpr std::uint32_t kScoringL1 = 1;
constexpr std::size_t kHeaderSize = 8 + 4 * 6 + 4 + 8 + 8 + 4 * 2;
constexpr std::size_t kNodeSize = 1 + 32;

std::uint64_t fnv1a(const std::uint8_t* data, std::size_t size) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

class Writer {
 public:
  std::vector<std::uint8_t> bytes;
  void u8(std::uint8_t v) { bytes.push_back(v); }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i)
      bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i)
      bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
};

class Reader {
 public:
  Reader(const std::vector<std::uint8_t>& bytes, std::string file)
      : bytes_(bytes), file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& message, const std::string& field,
                         std::size_t at) const {
    throw Error("vocabulary file: " + message, {.file = file_, .field = field, .offset = at});
  }
  std::uint64_t uint(int n, const std::string& field) {
    if (offset_ + static_cast<std::size_t>(n) > bytes_.size()) fail("truncated", field, offset_);
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i)
      v |= static_cast<std::uint64_t>(bytes_[offset_ + static_cast<std::size_t>(i)]) << (8 * i);
    offset_ += static_cast<std::size_t>(n);
    return v;
  }
  std::uint32_t u32(const std::string& field) { return static_cast<std::uint32_t>(uint(4, field)); }
  std::size_t offset() const { return offset_; }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::string file_;
  std::size_t offset_ = 0;
};

// Magic, version and checksum: what makes a file ours and intact, checked before anything in it
// is trusted. Leaves `r` after the version field.
void check_envelope(const std::vector<std::uint8_t>& bytes, Reader& r) {
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0) {
    r.fail("not a coloc vocabulary (bad magic; expected \"COLOCVOC\")", "magic", 0);
  }
  r.uint(8, "magic");
  const std::uint32_t version = r.u32("version");
  if (version != kVersion) {
    r.fail("unsupported version " + std::to_string(version) + " (this build reads version " +
               std::to_string(kVersion) + ")",
           "version", 8);
  }
  if (bytes.size() < kHeaderSize + 8) r.fail("truncated", "header", bytes.size());
  const std::size_t body = bytes.size() - 8;
  std::uint64_t stored = 0;
  for (int i = 0; i < 8; ++i) {
    stored |= static_cast<std::uint64_t>(bytes[body + static_cast<std::size_t>(i)]) << (8 * i);
  }
  if (stored != fnv1a(bytes.data(), body)) {
    r.fail("checksum mismatch: the file is damaged or truncated", "checksum", body);
  }
}

}  // namespace

std::vector<std::uint8_t> Vocabulary::serialize() const {
  if (nodes_.empty()) throw Error("vocabulary: cannot save an empty vocabulary");
  Writer w;
  w.bytes.reserve(kHeaderSize + nodes_.size() * kNodeSize + word_nodes_.size() * 4 + 8);
  for (char c : kMagic)
    w.u8(static_cast<std::uint8_t>(c));
  w.u32(kVersion);
  w.u32(static_cast<std::uint32_t>(info_.branching));
  w.u32(static_cast<std::uint32_t>(info_.depth));
  w.u32(kDescriptorBits);
  w.u32(kWeightingTfIdf);
  w.u32(kScoringL1);
  w.u32(info_.training_images);
  w.u64(info_.training_descriptors);
  w.u64(info_.seed);
  w.u32(static_cast<std::uint32_t>(nodes_.size()));
  w.u32(static_cast<std::uint32_t>(word_nodes_.size()));
  for (const Node& n : nodes_) {
    w.u8(static_cast<std::uint8_t>(n.child_count));
    for (std::uint64_t word : n.descriptor)
      w.u64(word);
  }
  for (double weight : word_weights_)
    w.f32(static_cast<float>(weight));
  w.u64(fnv1a(w.bytes.data(), w.bytes.size()));
  return w.bytes;
}

void Vocabulary::save(const std::filesystem::path& path) const {
  const std::vector<std::uint8_t> bytes = serialize();
  write_file_atomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Vocabulary Vocabulary::load(const std::filesystem::path& path) {
  check_input_file(path, "vocabulary file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open vocabulary file", {.file = path.string()});
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  return deserialize(bytes, path);
}

Vocabulary Vocabulary::deserialize(const std::vector<std::uint8_t>& bytes,
                                   const std::filesystem::path& source) {
  Reader r(bytes, source.string());
  check_envelope(bytes, r);

  Vocabulary v;
  const std::size_t params_at = r.offset();
  v.info_.branching = static_cast<int>(r.u32("branching"));
  v.info_.depth = static_cast<int>(r.u32("depth"));
  if (r.u32("descriptor_bits") != kDescriptorBits)
    r.fail("unsupported descriptor size", "descriptor_bits", params_at + 8);
  if (r.u32("weighting") != kWeightingTfIdf)
    r.fail("unsupported weighting", "weighting", params_at + 12);
  if (r.u32("scoring") != kScoringL1) r.fail("unsupported scoring", "scoring", params_at + 16);
  if (v.info_.branching < 2 || v.info_.branching > 255)
    r.fail("branching out of range", "branching", params_at);
  if (v.info_.depth < 1 || v.info_.depth > 10) r.fail("depth out of range", "depth", params_at + 4);
  v.info_.training_images = r.u32("training_images");
  v.info_.training_descriptors = r.uint(8, "training_descriptors");
  v.info_.seed = r.uint(8, "seed");
  const std::size_t counts_at = r.offset();
  const std::uint32_t node_count = r.u32("node_count");
  const std::uint32_t word_count = r.u32("word_count");
  if (node_count == 0 || word_count == 0 || word_count > node_count ||
      kHeaderSize + std::uint64_t{node_count} * kNodeSize + std::uint64_t{word_count} * 4 + 8 !=
          bytes.size()) {
    r.fail("node/word counts do not match the file size", "node_count", counts_at);
  }

  v.nodes_.resize(node_count);
  std::vector<int> level(node_count, 0);
  std::uint64_t next_child = 1;
  for (std::uint32_t n = 0; n < node_count; ++n) {
    const std::size_t at = r.offset();
    Node& node = v.nodes_[n];
    node.child_count = static_cast<std::uint32_t>(r.uint(1, "child_count"));
    for (auto& word : node.descriptor)
      word = r.uint(8, "descriptor");
    if (node.child_count == 0) {
      node.word = static_cast<WordId>(v.word_nodes_.size());
      v.word_nodes_.push_back(n);
      continue;
    }
    if (node.child_count > static_cast<std::uint32_t>(v.info_.branching) ||
        next_child + node.child_count > node_count || level[n] >= v.info_.depth) {
      r.fail("inconsistent tree (node " + std::to_string(n) + ")", "child_count", at);
    }
    node.first_child = static_cast<NodeId>(next_child);
    for (std::uint32_t c = 0; c < node.child_count; ++c)
      level[next_child + c] = level[n] + 1;
    next_child += node.child_count;
  }
  if (next_child != node_count || v.word_nodes_.size() != word_count) {
    r.fail("inconsistent tree (node and word counts disagree)", "node_count", counts_at);
  }
  v.word_weights_.resize(word_count);
  for (std::uint32_t w = 0; w < word_count; ++w) {
    const std::size_t at = r.offset();
    const float weight = std::bit_cast<float>(r.u32("weight"));
    if (!std::isfinite(weight) || weight < 0.0f) r.fail("invalid word weight", "weight", at);
    v.word_weights_[w] = weight;
  }
  v.info_.node_count = node_count;
  v.info_.word_count = word_count;
  return v;
}

}  // namespace coloc::slam::bow
