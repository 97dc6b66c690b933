#include "slam/tuning/tuning.hpp"

#include <array>
#include <cmath>
#include <sstream>
#include <variant>

#include "slam/core/error.hpp"

namespace coloc::slam::system {
namespace {

using Field = std::variant<int*, double*, bool*, std::size_t*>;

struct Tunable {
  const char* name;
  Field (*field)(SystemOptions&);
};

// clang-format off
constexpr std::array kTunables{
  Tunable{"tracking.min_init_points", [](SystemOptions& o) -> Field { return &o.tracking.min_init_points; }},
  Tunable{"tracking.motion_search_radius", [](SystemOptions& o) -> Field { return &o.tracking.motion_search_radius; }},
  Tunable{"tracking.local_search_th", [](SystemOptions& o) -> Field { return &o.tracking.local_search_th; }},
  Tunable{"tracking.min_local_inliers", [](SystemOptions& o) -> Field { return &o.tracking.min_local_inliers; }},
  Tunable{"tracking.min_local_inliers_after_reloc", [](SystemOptions& o) -> Field { return &o.tracking.min_local_inliers_after_reloc; }},
  Tunable{"tracking.max_frames_between_keyframes", [](SystemOptions& o) -> Field { return &o.tracking.max_frames_between_keyframes; }},
  Tunable{"tracking.min_frames_between_keyframes", [](SystemOptions& o) -> Field { return &o.tracking.min_frames_between_keyframes; }},
  Tunable{"tracking.early_keyframe_rotation_deg", [](SystemOptions& o) -> Field { return &o.tracking.early_keyframe_rotation_deg; }},
  Tunable{"tracking.early_keyframe_translation_m", [](SystemOptions& o) -> Field { return &o.tracking.early_keyframe_translation_m; }},
  Tunable{"tracking.min_frames_between_slow_keyframes", [](SystemOptions& o) -> Field { return &o.tracking.min_frames_between_slow_keyframes; }},
  Tunable{"tracking.close_tracked_limit", [](SystemOptions& o) -> Field { return &o.tracking.close_tracked_limit; }},
  Tunable{"tracking.close_untracked_limit", [](SystemOptions& o) -> Field { return &o.tracking.close_untracked_limit; }},
  Tunable{"tracking.reference_ratio", [](SystemOptions& o) -> Field { return &o.tracking.reference_ratio; }},
  Tunable{"tracking.new_points_min", [](SystemOptions& o) -> Field { return &o.tracking.new_points_min; }},
  Tunable{"tracking.max_local_keyframes", [](SystemOptions& o) -> Field { return &o.tracking.max_local_keyframes; }},
  Tunable{"tracking.weak_reference_ratio", [](SystemOptions& o) -> Field { return &o.tracking.weak_reference_ratio; }},
  Tunable{"tracking.motion_prior_sigma_m", [](SystemOptions& o) -> Field { return &o.tracking.motion_prior_sigma_m; }},
  Tunable{"tracking.motion_prior_max_matches", [](SystemOptions& o) -> Field { return &o.tracking.motion_prior_max_matches; }},
  Tunable{"tracking.keyframe_defer_ratio", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_defer_ratio; }},
  Tunable{"tracking.keyframe_defer_max", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_defer_max; }},
  Tunable{"tracking.keyframe_defer_deviation_deg", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_defer_deviation_deg; }},
  Tunable{"tracking.keyframe_defer_deviation_max", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_defer_deviation_max; }},
  Tunable{"tracking.keyframe_needs_idle_mapper", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_needs_idle_mapper; }},
  Tunable{"tracking.readout_settle_keyframes", [](SystemOptions& o) -> Field { return &o.tracking.readout_settle_keyframes; }},
  Tunable{"tracking.keyframe_keeps_outliers", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_keeps_outliers; }},
  Tunable{"tracking.rolling_shutter_keep_ratio", [](SystemOptions& o) -> Field { return &o.tracking.rolling_shutter_keep_ratio; }},
  Tunable{"tracking.rolling_shutter_rate_sigma", [](SystemOptions& o) -> Field { return &o.tracking.rolling_shutter_rate_sigma; }},
  Tunable{"tracking.reloc_gate_seconds", [](SystemOptions& o) -> Field { return &o.tracking.reloc_gate_seconds; }},
  Tunable{"tracking.reloc_gate_m", [](SystemOptions& o) -> Field { return &o.tracking.reloc_gate_m; }},
  Tunable{"tracking.reloc_gate_speed", [](SystemOptions& o) -> Field { return &o.tracking.reloc_gate_speed; }},
  Tunable{"tracking.reloc_gate_localizing_m", [](SystemOptions& o) -> Field { return &o.tracking.reloc_gate_localizing_m; }},
  Tunable{"tracking.reloc_pause_min_inliers", [](SystemOptions& o) -> Field { return &o.tracking.reloc_pause_min_inliers; }},
  Tunable{"tracking.keyframe_depth_factor", [](SystemOptions& o) -> Field { return &o.tracking.keyframe_depth_factor; }},
  Tunable{"tracking.relocalization.min_inliers", [](SystemOptions& o) -> Field { return &o.tracking.relocalization.min_inliers; }},
  Tunable{"tracking.relocalization.max_candidates", [](SystemOptions& o) -> Field { return &o.tracking.relocalization.max_candidates; }},
  Tunable{"tracking.relocalization.ransac_iterations", [](SystemOptions& o) -> Field { return &o.tracking.relocalization.ransac_iterations; }},
  Tunable{"mapping.queue_capacity", [](SystemOptions& o) -> Field { return &o.mapping.queue_capacity; }},
  Tunable{"mapping.fusion_neighbours", [](SystemOptions& o) -> Field { return &o.mapping.fusion_neighbours; }},
  Tunable{"mapping.fusion_radius", [](SystemOptions& o) -> Field { return &o.mapping.fusion_radius; }},
  Tunable{"mapping.triangulation", [](SystemOptions& o) -> Field { return &o.mapping.triangulation; }},
  Tunable{"mapping.local_ba", [](SystemOptions& o) -> Field { return &o.mapping.local_ba; }},
  Tunable{"mapping.ba.iterations_robust", [](SystemOptions& o) -> Field { return &o.mapping.ba.iterations_robust; }},
  Tunable{"mapping.ba.iterations_refine", [](SystemOptions& o) -> Field { return &o.mapping.ba.iterations_refine; }},
  Tunable{"mapping.ba.dense_schur_max_poses", [](SystemOptions& o) -> Field { return &o.mapping.ba.dense_schur_max_poses; }},
  Tunable{"mapping.ba.own_dense_solver", [](SystemOptions& o) -> Field { return &o.mapping.ba.own_dense_solver; }},
  Tunable{"mapping.keyframe_culling", [](SystemOptions& o) -> Field { return &o.mapping.keyframe_culling; }},
  Tunable{"mapping.redundancy", [](SystemOptions& o) -> Field { return &o.mapping.redundancy; }},
  Tunable{"mapping.redundancy_straight", [](SystemOptions& o) -> Field { return &o.mapping.redundancy_straight; }},
  Tunable{"mapping.straight_turn_deg", [](SystemOptions& o) -> Field { return &o.mapping.straight_turn_deg; }},
  Tunable{"mapping.estimate_readout", [](SystemOptions& o) -> Field { return &o.mapping.estimate_readout; }},
  Tunable{"mapping.readout_step", [](SystemOptions& o) -> Field { return &o.mapping.readout_step; }},
  Tunable{"mapping.readout_publish", [](SystemOptions& o) -> Field { return &o.mapping.readout_publish; }},
  Tunable{"mapping.readout_start", [](SystemOptions& o) -> Field { return &o.mapping.readout_start; }},
  Tunable{"mapping.readout_min_keyframes", [](SystemOptions& o) -> Field { return &o.mapping.readout_min_keyframes; }},
  Tunable{"loop.enabled", [](SystemOptions& o) -> Field { return &o.loop.enabled; }},
  Tunable{"loop.min_consistency", [](SystemOptions& o) -> Field { return &o.loop.min_consistency; }},
  Tunable{"loop.min_inliers", [](SystemOptions& o) -> Field { return &o.loop.min_inliers; }},
  Tunable{"loop.max_drift_m", [](SystemOptions& o) -> Field { return &o.loop.max_drift_m; }},
  Tunable{"loop.max_drift_per_m", [](SystemOptions& o) -> Field { return &o.loop.max_drift_per_m; }},
  Tunable{"loop.max_rotation_drift", [](SystemOptions& o) -> Field { return &o.loop.max_rotation_drift; }},
  Tunable{"loop.max_rotation_drift_per_m", [](SystemOptions& o) -> Field { return &o.loop.max_rotation_drift_per_m; }},
  Tunable{"loop.free_space_test", [](SystemOptions& o) -> Field { return &o.loop.free_space_test; }},
  Tunable{"loop.max_free_space_violation", [](SystemOptions& o) -> Field { return &o.loop.max_free_space_violation; }},
  Tunable{"loop.current_pose_hypothesis", [](SystemOptions& o) -> Field { return &o.loop.current_pose_hypothesis; }},
  Tunable{"loop.current_pose_radius_px", [](SystemOptions& o) -> Field { return &o.loop.current_pose_radius_px; }},
  Tunable{"loop.global_ba", [](SystemOptions& o) -> Field { return &o.loop.global_ba; }},
  Tunable{"detect_markers", [](SystemOptions& o) -> Field { return &o.detect_markers; }},
};
// clang-format on

const Tunable* find(const std::string& name) {
  for (const Tunable& t : kTunables)
    if (name == t.name) return &t;
  return nullptr;
}

// Sets one option; the error text says what the value must be.
void assign(Field field, double value, const ErrorContext& where) {
  const bool integral = std::floor(value) == value && std::isfinite(value);
  std::visit(
      [&](auto* target) {
        using T = std::remove_pointer_t<decltype(target)>;
        if constexpr (std::is_same_v<T, double>) {
          *target = value;
        } else if constexpr (std::is_same_v<T, bool>) {
          if (value != 0.0 && value != 1.0) throw Error("expected 0 or 1", where);
          *target = value != 0.0;
        } else {
          if (!integral) throw Error("expected an integer", where);
          if (std::is_same_v<T, std::size_t> && value < 0.0)
            throw Error("expected a non-negative integer", where);
          *target = static_cast<T>(value);
        }
      },
      field);
}

}  // namespace

void apply_tuning(const settings::Settings& settings, SystemOptions& options) {
  for (const auto& [name, value] : settings.coloc_options) {
    const ErrorContext where{.file = settings.source.string(), .field = "Coloc." + name};
    const Tunable* t = find(name);
    if (!t) {
      std::string known;
      for (const Tunable& k : kTunables)
        known += std::string(known.empty() ? "" : ", ") + k.name;
      throw Error("unknown coloc option; the known ones: " + known, where);
    }
    assign(t->field(options), value, where);
  }
  try {
    options.check();
  } catch (const Error& e) {
    throw Error(e.what(), {.file = settings.source.string()});
  }
}

void SystemOptions::check() const {
  tracking.check();
  mapping.check();
  loop.check();
}

std::string SystemOptions::describe() const {
  return describe_tuning(*this) + "tracking.wait_for_sink " +
         std::to_string(tracking.wait_for_sink) + "\ntracking.rgb_input " +
         std::to_string(tracking.rgb_input);
}

std::string describe_tuning(const SystemOptions& options) {
  SystemOptions copy = options;  // the table's accessors take a mutable struct
  std::ostringstream s;
  for (const Tunable& t : kTunables) {
    s << t.name << ' ';
    std::visit([&](auto* v) { s << *v; }, t.field(copy));
    s << '\n';
  }
  return s.str();
}

}  // namespace coloc::slam::system
