#include <gtest/gtest.h>

#include "slam/bow/place_recall.hpp"
#include "slam/core/error.hpp"

namespace coloc::slam::bow {
namespace {

// A walk past 20 places, twice: image i sees place i % 20 (three words of its own) from a
// camera at x = place metres; `second_pass_offset` moves the cameras of the second pass.
struct Walk {
  std::vector<BowVector> bows;
  std::vector<SE3> world_from_cam;
};

Walk two_passes(double second_pass_offset) {
  Walk w;
  for (std::size_t i = 0; i < 40; ++i) {
    const auto place = static_cast<WordId>(i % 20);
    BowVector bow;
    for (WordId k = 0; k < 3; ++k)
      bow.entries.push_back({3 * place + k, 1.0 / 3.0});
    w.bows.push_back(bow);
    const double x = static_cast<double>(place) + (i >= 20 ? second_pass_offset : 0.0);
    w.world_from_cam.emplace_back(SO3(), Eigen::Vector3d(x, 0.0, 0.0));
  }
  return w;
}

TEST(PlaceRecall, RevisitedPlacesAreFoundAcrossTheExcludedNeighbourhood) {
  const Walk w = two_passes(0.0);
  // Queries 0, 7, ..., 35: each one's place was seen in the other pass, 20 frames away.
  const PlaceRecallResult r =
      evaluate_place_recall(w.bows, w.world_from_cam, {.query_step = 7, .exclude = 5});
  EXPECT_EQ(r.queries, 6u);
  EXPECT_EQ(r.database, 34u);
  EXPECT_EQ(r.answerable, 6u);
  EXPECT_EQ(r.hit1, 6u);
  EXPECT_EQ(r.hit_k, 6u);
  EXPECT_DOUBLE_EQ(r.recall_at_1(), 1.0);
  EXPECT_EQ(r.query_ms.size(), r.queries);
}

TEST(PlaceRecall, ARetrievalAtAnotherPoseIsNoHit) {
  // The second pass looks the same but its cameras are 0.5 m away (the hit radius is 0.3 m).
  const Walk w = two_passes(0.5);
  const PlaceRecallResult r =
      evaluate_place_recall(w.bows, w.world_from_cam, {.query_step = 7, .exclude = 5});
  EXPECT_EQ(r.answerable, 0u);
  EXPECT_EQ(r.hit_k, 0u);
  // Excluding every neighbour leaves no candidate at all.
  const PlaceRecallResult none = evaluate_place_recall(two_passes(0.0).bows, w.world_from_cam,
                                                       {.query_step = 7, .exclude = 40});
  EXPECT_EQ(none.hit_k, 0u);
}

TEST(PlaceRecall, RejectsMismatchedInputAndOptions) {
  const Walk w = two_passes(0.0);
  std::vector<SE3> short_poses(w.world_from_cam.begin(), w.world_from_cam.begin() + 10);
  EXPECT_THROW(evaluate_place_recall(w.bows, short_poses), Error);
  EXPECT_THROW(evaluate_place_recall(w.bows, w.world_from_cam, {.query_step = 1}), Error);
  EXPECT_THROW(evaluate_place_recall(w.bows, w.world_from_cam, {.max_distance = 0.0}), Error);
}

}  // namespace
}  // namespace coloc::slam::bow
