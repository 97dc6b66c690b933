// A user's program against the installed coloc: one call into each of a few modules (core,
// settings, eval, the SLAM pipeline's header), with the installed data. Exit 0 when each
// result is what it must be.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "slam/core/se3.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/core/version.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/pipeline/pipeline.hpp"
#include "slam/settings/settings.hpp"

int main() {
  namespace fs = std::filesystem;
  // The installed settings file the CLI uses for TUM recordings.
  const auto settings =
      coloc::settings::load_settings(fs::path(COLOC_DATA_DIR) / "settings/TUM1.yaml");
  // A trajectory against itself moved rigidly: the ATE after SE3 alignment is zero.
  coloc::Trajectory truth, moved;
  const coloc::SE3 offset(coloc::SO3::exp({0.0, 0.0, 0.5}), Eigen::Vector3d(1.0, 2.0, 0.0));
  for (int i = 0; i < 20; ++i) {
    const coloc::SE3 pose(coloc::SO3::exp({0.01 * i, 0.0, 0.02 * i}),
                          Eigen::Vector3d(0.1 * i, std::sin(0.3 * i), 0.05 * i));
    truth.push_back({0.1 * i, pose});
    moved.push_back({0.1 * i, offset * pose});
  }
  const auto ate = coloc::eval::compute_ate(truth, moved);
  const coloc::slam::pipeline::RunOptions run;
  std::printf("consumer: coloc %s (%s), settings %dx%d, ATE %.2e m, pipeline %s\n",
              std::string(coloc::version()).c_str(), std::string(coloc::git_hash()).c_str(),
              coloc::image_width(settings.camera), coloc::image_height(settings.camera),
              ate.translation.rmse, coloc::slam::pipeline::pacing_name(run));
  return ate.translation.rmse < 1e-9 ? 0 : 1;
}
