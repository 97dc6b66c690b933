#include "slam/bow/place_recall.hpp"

#include <numbers>

#include "slam/bow/database.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::slam::bow {

void PlaceRecallOptions::check() const {
  if (query_step < 2) throw Error("must be at least 2", {.field = "query_step"});
  if (!(max_distance > 0.0)) throw Error("must be positive", {.field = "max_distance"});
  if (!(max_angle_deg > 0.0)) throw Error("must be positive", {.field = "max_angle_deg"});
  if (top_k < 1) throw Error("must be at least 1", {.field = "top_k"});
}

double PlaceRecallResult::recall_at_1() const {
  return queries == 0 ? 0.0 : static_cast<double>(hit1) / static_cast<double>(queries);
}

double PlaceRecallResult::recall_at_k() const {
  return queries == 0 ? 0.0 : static_cast<double>(hit_k) / static_cast<double>(queries);
}

PlaceRecallResult evaluate_place_recall(const std::vector<BowVector>& bows,
                                        const std::vector<SE3>& world_from_cam,
                                        const PlaceRecallOptions& options) {
  options.check();
  if (bows.size() != world_from_cam.size())
    throw Error("one pose per image wanted: " + std::to_string(bows.size()) + " images, " +
                    std::to_string(world_from_cam.size()) + " poses",
                {.field = "world_from_cam"});
  const std::size_t step = options.query_step;
  const double max_angle = options.max_angle_deg * std::numbers::pi / 180.0;
  BowDatabase database;
  for (std::size_t i = 0; i < bows.size(); ++i) {
    if (i % step != 0) database.add(i, bows[i]);
  }
  auto is_hit = [&](std::size_t q, std::size_t d) {
    const SE3 q_from_d = world_from_cam[q].inverse() * world_from_cam[d];
    return q_from_d.translation().norm() <= options.max_distance &&
           q_from_d.so3().log().norm() <= max_angle;
  };
  PlaceRecallResult r;
  r.database = database.size();
  for (std::size_t q = 0; q < bows.size(); q += step) {
    ++r.queries;
    auto far = [&](std::uint64_t d) { return d + options.exclude < q || d > q + options.exclude; };
    bool any_positive = false;
    for (std::size_t d = 0; d < bows.size() && !any_positive; ++d)
      any_positive = d % step != 0 && far(d) && is_hit(q, d);
    r.answerable += any_positive ? 1 : 0;
    QueryOptions query;
    query.max_results = options.top_k;
    query.accept = far;
    const Stopwatch watch;
    const auto results = database.query(bows[q], query);
    r.query_ms.push_back(watch.elapsed_ms());
    for (std::size_t k = 0; k < results.size(); ++k) {
      if (!is_hit(q, results[k].image)) continue;
      r.hit1 += k == 0 ? 1 : 0;
      ++r.hit_k;
      break;
    }
  }
  if (r.queries == 0) throw Error("no images to query", {.field = "bows"});
  return r;
}

}  // namespace coloc::slam::bow
