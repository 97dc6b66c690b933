// Coloc.* keys of a settings file: applied by name, every name and value checked.
#include <gtest/gtest.h>

#include "slam/core/error.hpp"
#include "slam/tuning/tuning.hpp"

namespace coloc::slam::system {
namespace {

settings::Settings with(std::map<std::string, double> options) {
  settings::Settings s;
  s.source = "site.yaml";
  s.coloc_options = std::move(options);
  return s;
}

// The error of apply_tuning names the file and (when given) the key.
void expect_rejected(std::map<std::string, double> options, const std::string& key) {
  SystemOptions o;
  try {
    apply_tuning(with(std::move(options)), o);
    FAIL() << "expected an error for " << key;
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "site.yaml") << e.what();
    EXPECT_EQ(e.context().field, key) << e.what();
  }
}

TEST(Tuning, KnownKeysSetTheirOptions) {
  SystemOptions o;
  apply_tuning(with({{"tracking.min_local_inliers", 40},
                     {"mapping.local_ba", 0},
                     {"mapping.redundancy", 0.8},
                     {"mapping.queue_capacity", 2},
                     {"tracking.relocalization.min_inliers", 60},
                     {"tracking.reference_ratio", 0.65},
                     {"mapping.ba.own_dense_solver", 0},
                     {"mapping.redundancy_straight", 0.5},
                     {"mapping.straight_turn_deg", 8}}),
               o);
  EXPECT_EQ(o.tracking.min_local_inliers, 40);
  EXPECT_FALSE(o.mapping.local_ba);
  EXPECT_DOUBLE_EQ(o.mapping.redundancy, 0.8);
  EXPECT_EQ(o.mapping.queue_capacity, 2u);
  EXPECT_EQ(o.tracking.relocalization.min_inliers, 60);
  EXPECT_DOUBLE_EQ(o.tracking.reference_ratio, 0.65);
  EXPECT_FALSE(o.mapping.ba.own_dense_solver);  // every BA back to Ceres
  EXPECT_DOUBLE_EQ(o.mapping.redundancy_straight, 0.5);
  EXPECT_DOUBLE_EQ(o.mapping.straight_turn_deg, 8.0);
  // The effective values are printed by the same names.
  const std::string d = o.describe();
  EXPECT_NE(d.find("tracking.min_local_inliers 40\n"), std::string::npos) << d;
  EXPECT_NE(d.find("mapping.local_ba 0\n"), std::string::npos) << d;
}

TEST(Tuning, UnknownNamesWrongTypesAndInvalidValuesAreErrors) {
  expect_rejected({{"tracking.min_local_inlier", 40}}, "Coloc.tracking.min_local_inlier");
  expect_rejected({{"tracking.min_local_inliers", 40.5}}, "Coloc.tracking.min_local_inliers");
  expect_rejected({{"mapping.local_ba", 2}}, "Coloc.mapping.local_ba");
  expect_rejected({{"mapping.queue_capacity", -1}}, "Coloc.mapping.queue_capacity");
  expect_rejected({{"mapping.ba.own_dense_solver", 0.5}}, "Coloc.mapping.ba.own_dense_solver");
  // A value of the right type that the options reject: the file is named, the message says why.
  expect_rejected({{"tracking.min_local_inliers", 3}}, "");
  expect_rejected({{"tracking.reference_ratio", 1.5}}, "");
  expect_rejected({{"mapping.redundancy_straight", 0.0}}, "");
  expect_rejected({{"mapping.straight_turn_deg", -1}}, "");
}

}  // namespace
}  // namespace coloc::slam::system
