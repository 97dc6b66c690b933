#pragma once
// Place recognition: an inverse index (word -> images containing it, with the word's weight)
// over the BoW vectors of a set of images (keyframes), queried for the most similar ones.
//
// A query scores only the images sharing a word with it (the inverse index makes this cheap),
// drops those sharing fewer than `min_common_words_ratio` times the best candidate's common
// words, then ranks by L1 score. With a `neighbours` function (ORB-SLAM passes the covisible
// keyframes), each candidate's score is accumulated over the candidates among its neighbours
// and groups scoring below `group_score_ratio` of the best group are dropped; each group is
// represented by its best-scoring member (ORB-SLAM's relocalisation / loop candidate grouping).
//
// Ids are the caller's (a keyframe id value, a frame index). Not thread-safe for concurrent
// add/erase; concurrent const queries are fine.

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "slam/bow/bow_vector.hpp"

namespace coloc::slam::bow {

using ImageKey = std::uint64_t;

struct QueryOptions {
  std::size_t max_results = 5;
  double min_common_words_ratio = 0.8;  // in [0, 1]; 0 keeps every candidate
  double min_score = 0.0;
  // Optional covisibility-style grouping: the images whose scores join an image's group.
  std::function<std::vector<ImageKey>(ImageKey)> neighbours;
  double group_score_ratio = 0.75;  // groups below this fraction of the best are dropped
  // Optional filter: only images for which this returns true are candidates.
  std::function<bool(ImageKey)> accept;

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct QueryResult {
  ImageKey image = 0;
  double score = 0.0;        // L1 score of this image against the query
  double group_score = 0.0;  // accumulated over its group (equals score without grouping)
  std::uint32_t common_words = 0;
};

class BowDatabase {
 public:
  // Throws coloc::Error if `image` is already present.
  void add(ImageKey image, const BowVector& bow);
  // Removes an image; returns false if it was not present.
  bool erase(ImageKey image);
  bool contains(ImageKey image) const { return slot_of_.count(image) > 0; }
  std::size_t size() const { return slot_of_.size(); }
  void clear();
  // Room for the postings of images about to be added (a bulk load: slam/mapdb adds every
  // keyframe of a map): each word's postings get their final capacity at once. Grown by
  // doubling, a quarter of it went unused on average, and the outgrown arrays stayed behind as
  // free holes in the heap (some 7 MB each at a site map of 1,456 keyframes).
  void reserve(const std::vector<const BowVector*>& images);

  // Best images first (by group score, then score, then key). At most options.max_results.
  std::vector<QueryResult> query(const BowVector& bow, const QueryOptions& options = {}) const;

 private:
  struct Posting {
    std::uint32_t slot;
    double weight;
  };
  std::unordered_map<WordId, std::vector<Posting>> inverse_;
  std::unordered_map<ImageKey, std::uint32_t> slot_of_;
  std::vector<ImageKey> key_of_;  // per slot
  // Per slot, the image's words (empty when the slot is free): what erase() needs to find its
  // postings. Not its BowVector: the weights are in the postings already, and a copy of every
  // vector was 16 bytes a word, 12 more than the word (a site map: 1,464 images).
  std::vector<std::vector<WordId>> words_;
  std::vector<std::uint32_t> free_slots_;
};

}  // namespace coloc::slam::bow
