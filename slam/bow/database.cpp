#include "slam/bow/database.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::slam::bow {

void QueryOptions::check() const {
  if (max_results == 0)
    throw Error("invalid query option: must be at least 1", {.field = "max_results"});
  if (!(min_common_words_ratio >= 0.0 && min_common_words_ratio <= 1.0)) {
    throw Error("invalid query option: must be in [0, 1]", {.field = "min_common_words_ratio"});
  }
  if (!(group_score_ratio >= 0.0 && group_score_ratio <= 1.0)) {
    throw Error("invalid query option: must be in [0, 1]", {.field = "group_score_ratio"});
  }
}

void BowDatabase::add(ImageKey image, const BowVector& bow) {
  if (contains(image)) {
    throw Error("bag-of-words database: image " + std::to_string(image) + " added twice");
  }
  std::vector<WordId> words;
  words.reserve(bow.entries.size());
  for (const auto& e : bow.entries)
    words.push_back(e.word);
  std::uint32_t slot = 0;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
    key_of_[slot] = image;
    words_[slot] = std::move(words);
  } else {
    slot = static_cast<std::uint32_t>(key_of_.size());
    key_of_.push_back(image);
    words_.push_back(std::move(words));
  }
  slot_of_[image] = slot;
  for (const auto& e : bow.entries)
    inverse_[e.word].push_back({slot, e.weight});
}

void BowDatabase::reserve(const std::vector<const BowVector*>& images) {
  // Every word of every image, sorted: the runs are the postings each word gains (one array,
  // where a count per word would be one small allocation per word).
  std::vector<WordId> all;
  std::size_t total = 0;
  for (const BowVector* bow : images)
    total += bow->entries.size();
  all.reserve(total);
  for (const BowVector* bow : images)
    for (const auto& e : bow->entries)
      all.push_back(e.word);
  std::sort(all.begin(), all.end());
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i;
    while (j < all.size() && all[j] == all[i])
      ++j;
    std::vector<Posting>& postings = inverse_[all[i]];
    postings.reserve(postings.size() + (j - i));
    i = j;
  }
  key_of_.reserve(key_of_.size() + images.size());
  words_.reserve(words_.size() + images.size());
  slot_of_.reserve(slot_of_.size() + images.size());
}

bool BowDatabase::erase(ImageKey image) {
  const auto it = slot_of_.find(image);
  if (it == slot_of_.end()) return false;
  const std::uint32_t slot = it->second;
  for (const WordId word : words_[slot]) {
    auto& postings = inverse_[word];
    std::erase_if(postings, [slot](const Posting& p) { return p.slot == slot; });
    if (postings.empty()) inverse_.erase(word);
  }
  words_[slot] = {};
  free_slots_.push_back(slot);
  slot_of_.erase(it);
  return true;
}

void BowDatabase::clear() {
  inverse_.clear();
  slot_of_.clear();
  key_of_.clear();
  words_.clear();
  free_slots_.clear();
}

namespace {

bool better(const QueryResult& a, const QueryResult& b) {
  if (a.group_score != b.group_score) return a.group_score > b.group_score;
  if (a.score != b.score) return a.score > b.score;
  return a.image < b.image;
}

}  // namespace

std::vector<QueryResult> BowDatabase::query(const BowVector& bow,
                                            const QueryOptions& options) const {
  options.check();
  // Accumulate, per image sharing a word, the common-word count and the L1 partial sum (see
  // score_l1), in the query's word order so results do not depend on hash order.
  struct Accumulator {
    std::uint32_t common = 0;
    bool rejected = false;  // by options.accept, asked once per image
    double sum = 0.0;
  };
  std::vector<Accumulator> acc(key_of_.size());
  std::vector<std::uint32_t> touched;
  for (const auto& q : bow.entries) {
    const auto it = inverse_.find(q.word);
    if (it == inverse_.end()) continue;
    for (const Posting& p : it->second) {
      Accumulator& a = acc[p.slot];
      if (a.rejected) continue;
      if (a.common == 0) {
        if (options.accept && !options.accept(key_of_[p.slot])) {
          a.rejected = true;
          continue;
        }
        touched.push_back(p.slot);
      }
      ++a.common;
      a.sum += std::abs(q.weight - p.weight) - (std::abs(q.weight) + std::abs(p.weight));
    }
  }
  std::uint32_t max_common = 0;
  for (std::uint32_t s : touched)
    max_common = std::max(max_common, acc[s].common);
  const double min_common = options.min_common_words_ratio * max_common;

  std::vector<QueryResult> candidates;
  std::unordered_map<ImageKey, double> score_of;
  for (std::uint32_t s : touched) {
    if (acc[s].common < min_common) continue;
    const double score = -0.5 * acc[s].sum;
    if (score < options.min_score) continue;
    candidates.push_back({key_of_[s], score, score, acc[s].common});
    score_of[key_of_[s]] = score;
  }
  if (!options.neighbours) {
    std::sort(candidates.begin(), candidates.end(), better);
    if (candidates.size() > options.max_results) candidates.resize(options.max_results);
    return candidates;
  }

  // Group scoring: each candidate's group is itself plus its neighbours that are candidates;
  // the group is represented by its best member.
  double best_group = 0.0;
  std::vector<QueryResult> groups;
  for (const QueryResult& c : candidates) {
    QueryResult representative = c;
    double group_score = c.score;
    for (ImageKey n : options.neighbours(c.image)) {
      const auto it = score_of.find(n);
      if (it == score_of.end() || n == c.image) continue;
      group_score += it->second;
      if (it->second > representative.score ||
          (it->second == representative.score && n < representative.image)) {
        representative = QueryResult{n, it->second, 0.0, acc[slot_of_.at(n)].common};
      }
    }
    representative.group_score = group_score;
    best_group = std::max(best_group, group_score);
    groups.push_back(representative);
  }
  std::vector<QueryResult> results;
  std::sort(groups.begin(), groups.end(), better);
  for (const QueryResult& g : groups) {
    if (g.group_score < options.group_score_ratio * best_group) break;
    const bool seen = std::any_of(results.begin(), results.end(),
                                  [&](const QueryResult& r) { return r.image == g.image; });
    if (!seen) results.push_back(g);
    if (results.size() == options.max_results) break;
  }
  return results;
}

}  // namespace coloc::slam::bow
