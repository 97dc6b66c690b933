#pragma once
// Place-recognition recall of a vocabulary on a posed image sequence (`coloc bench bow`): every
// `query_step`-th image queries a BowDatabase of the other images, minus those within
// `exclude` frames of it (its own neighbourhood would make the test trivial). A retrieved image
// is a hit when its camera is within `max_distance` metres and `max_angle_deg` degrees of the
// query's; recall@k counts the queries with a hit among the first k results.

#include <cstddef>
#include <vector>

#include "slam/bow/bow_vector.hpp"
#include "slam/core/se3.hpp"

namespace coloc::slam::bow {

struct PlaceRecallOptions {
  std::size_t query_step = 10;  // every n-th image is a query and is left out of the database
  std::size_t exclude = 15;     // database images within +-exclude frames are not candidates
  double max_distance = 0.3;    // metres between the two camera centres
  double max_angle_deg = 20.0;  // relative rotation angle
  std::size_t top_k = 5;        // results per query (recall@1 and recall@top_k)

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct PlaceRecallResult {
  std::size_t queries = 0;
  std::size_t answerable = 0;    // queries with a true match among their candidates
  std::size_t database = 0;      // images in the database
  std::size_t hit1 = 0;          // queries whose first result is a hit
  std::size_t hit_k = 0;         // queries with a hit among the first top_k results
  std::vector<double> query_ms;  // wall time of each database query

  double recall_at_1() const;
  double recall_at_k() const;
};

// `bows[i]` and `world_from_cam[i]` describe image i of a sequence in recording order. Throws
// coloc::Error when the two differ in length or there are no queries.
PlaceRecallResult evaluate_place_recall(const std::vector<BowVector>& bows,
                                        const std::vector<SE3>& world_from_cam,
                                        const PlaceRecallOptions& options = {});

}  // namespace coloc::slam::bow
