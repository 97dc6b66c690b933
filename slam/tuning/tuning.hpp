#pragma once
// The SLAM options a user may tune from a camera settings file, as `Coloc.<name>: value`
// (`Coloc.tracking.min_local_inliers: 40`, `Coloc.mapping.local_ba: 0`). One table names them,
// so the keys that are read, the effective values printed at start and the names in error
// messages always agree. Values are numbers; booleans are 0 / 1.
#include <string>

#include "slam/settings/settings.hpp"
#include "slam/tuning/system_options.hpp"

namespace coloc::slam::system {

// Applies settings.coloc_options to `options`, then checks them. Throws coloc::Error naming the
// settings file and the key for an unknown name, a non-integer where an integer is needed, or a
// value the options' check() rejects.
void apply_tuning(const settings::Settings& settings, SystemOptions& options);

// Every tunable option with its effective value, one `name value` per line (logged at start).
std::string describe_tuning(const SystemOptions& options);

}  // namespace coloc::slam::system
