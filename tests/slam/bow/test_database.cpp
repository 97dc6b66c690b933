#include <gtest/gtest.h>

#include "slam/bow/database.hpp"
#include "slam/bow/matcher.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/error.hpp"
#include "tests/slam/bow/synthetic.hpp"

namespace coloc::slam::bow {
namespace {

struct Fixture {
  testing::SyntheticSet set = testing::make_synthetic_set(11);
  Vocabulary vocabulary =
      Vocabulary::train(set.images, {.branching = 4, .depth = 3, .max_iterations = 10, .seed = 2});
  std::vector<BowVector> bows;
  Fixture() {
    for (const auto& image : set.images)
      bows.push_back(vocabulary.transform(image));
  }
};

TEST(BowDatabase, FindsTheImageItselfFirstAndRespectsTheFilter) {
  const Fixture f;
  BowDatabase database;
  for (std::size_t i = 0; i < f.bows.size(); ++i)
    database.add(100 + i, f.bows[i]);
  EXPECT_EQ(database.size(), f.bows.size());
  EXPECT_THROW(database.add(100, f.bows[0]), Error);
  for (std::size_t i = 0; i < f.bows.size(); ++i) {
    const auto results = database.query(f.bows[i]);
    ASSERT_FALSE(results.empty());
    EXPECT_EQ(results[0].image, 100 + i);
    EXPECT_NEAR(results[0].score, 1.0, 1e-9);
    EXPECT_LE(results.size(), 5U);
    for (std::size_t r = 1; r < results.size(); ++r) {
      EXPECT_GE(results[r - 1].score, results[r].score);
      EXPECT_NEAR(results[r].score, score_l1(f.bows[i], f.bows[results[r].image - 100]), 1e-9);
    }
  }
  QueryOptions options;
  options.accept = [](ImageKey k) { return k != 103; };
  options.min_common_words_ratio = 0.0;
  options.max_results = 100;
  const auto results = database.query(f.bows[3], options);
  EXPECT_EQ(results.size(), f.bows.size() - 1);  // every other image shares some word
  for (const auto& r : results)
    EXPECT_NE(r.image, 103U);
}

TEST(BowDatabase, EraseRemovesFromTheInverseIndex) {
  const Fixture f;
  BowDatabase database;
  for (std::size_t i = 0; i < f.bows.size(); ++i)
    database.add(i, f.bows[i]);
  EXPECT_TRUE(database.erase(4));
  EXPECT_FALSE(database.erase(4));
  EXPECT_FALSE(database.contains(4));
  QueryOptions options;
  options.min_common_words_ratio = 0.0;
  options.max_results = 100;
  for (const auto& r : database.query(f.bows[4], options))
    EXPECT_NE(r.image, 4U);
  database.add(4, f.bows[4]);  // the slot is reused
  EXPECT_EQ(database.query(f.bows[4])[0].image, 4U);
  database.clear();
  EXPECT_TRUE(database.query(f.bows[4]).empty());
}

TEST(BowDatabase, GroupsAccumulateOverNeighbours) {
  // Image 0 is the best single match but alone; 1 and 2 are neighbours of each other and
  // together outscore it, so grouping returns the better of 1 and 2 first.
  BowDatabase database;
  database.add(0, {{{1, 0.6}, {2, 0.4}}});
  database.add(1, {{{1, 0.5}, {3, 0.5}}});
  database.add(2, {{{1, 0.45}, {4, 0.55}}});
  const BowVector query{{{1, 0.7}, {2, 0.3}}};
  QueryOptions plain;
  plain.min_common_words_ratio = 0.0;
  EXPECT_EQ(database.query(query, plain)[0].image, 0U);
  QueryOptions grouped = plain;
  grouped.neighbours = [](ImageKey k) {
    if (k == 1) return std::vector<ImageKey>{2};
    if (k == 2) return std::vector<ImageKey>{1};
    return std::vector<ImageKey>{};
  };
  const auto results = database.query(query, grouped);
  ASSERT_FALSE(results.empty());
  EXPECT_EQ(results[0].image, 1U);
  EXPECT_NEAR(results[0].group_score,
              score_l1(query, {{{1, 0.5}, {3, 0.5}}}) + score_l1(query, {{{1, 0.45}, {4, 0.55}}}),
              1e-12);
  QueryOptions bad;
  bad.min_common_words_ratio = 2.0;
  EXPECT_THROW(database.query(query, bad), Error);
}

TEST(BowMatcher, RotationFilterKeepsTheConsistentMajority) {
  features::OrbFeatures a;
  features::OrbFeatures b;
  std::vector<FeatureMatch> matches;
  for (std::uint32_t i = 0; i < 40; ++i) {
    a.keypoints.push_back({.angle = 0.1f * static_cast<float>(i % 6)});
    // 36 matches rotated by 0.5 rad; 4 outliers, each with a rotation of its own.
    const float rotation = i < 36 ? 0.5f : 1.5f + static_cast<float>(i - 36);
    float angle_b = a.keypoints.back().angle - rotation;
    if (angle_b < 0) angle_b += 6.2831853f;
    b.keypoints.push_back({.angle = angle_b});
    matches.push_back({i, i, 10});
  }
  const auto kept = filter_by_rotation(a, b, matches, 30);
  EXPECT_EQ(kept.size(), 36U);
  for (const auto& m : kept)
    EXPECT_LT(m.index_a, 36U);
  EXPECT_THROW(match_by_bow(a, {}, b, {}, {.ratio = 0.0}), Error);
}

}  // namespace
}  // namespace coloc::slam::bow
