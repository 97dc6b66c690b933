#pragma once
// The registration pipeline (Michiels et al. 2024, section 4.4) on a loaded map: marker corners
// in the SLAM frame, rough alignment, the map moved into the scan's frame, and (level markers)
// the global BA with the fixed scanned corners. The map comes out in the scan's frame.
//
// Markers entering the BA: every marker common to the map and the scan that the leave-one-out
// test of rough alignment finds consistent and whose rough residual is below
// ba_max_rough_residual (metres): the rough inlier threshold is about the transform and
// must tolerate drift, while the BA judges a marker by its reprojection error once the drift is
// gone (marker_ba.hpp); only grossly wrong markers are kept out of its first pass.
#include <optional>
#include <string>

#include "markers/marker_map.hpp"
#include "registration/align/marker_ba.hpp"
#include "registration/align/refine.hpp"
#include "registration/align/rough.hpp"
#include "registration/align/slam_markers.hpp"

namespace coloc::registration::align {

enum class Level { kRough, kMarkers, kPointcloud };
const char* level_name(Level level);
// "rough", "markers" or "pointcloud"; throws coloc::Error (field "level") otherwise.
Level parse_level(const std::string& name);

struct RegisterOptions {
  Level level = Level::kMarkers;
  SlamMarkerOptions corners;
  RoughOptions rough;
  MarkerBaOptions ba;
  RefineOptions refine;                // level pointcloud
  double ba_max_rough_residual = 1.0;  // metres (see the header)
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct RegistrationResult {
  Level level = Level::kRough;
  SlamMarkers slam_markers;
  RoughAlignment rough;
  std::optional<MarkerBaReport> ba;    // levels markers and pointcloud
  std::optional<RefineReport> refine;  // level pointcloud
  // The rigid (similarity) part: rough alignment's transform. The BA then deforms the map, so
  // no single transform maps the input onto the output at level markers.
  Sim3 scan_from_slam;
  double ms_corners = 0.0, ms_rough = 0.0, ms_ba = 0.0, ms_refine = 0.0;
};

// Registers `map` in place. Level pointcloud needs `cloud` (the scan's points, scan_cloud.hpp)
// and refines after the marker BA (refine.hpp); `progress` reports its keyframes. Throws
// coloc::Error from rough alignment (too few or inconsistent markers, naming them), for invalid
// options, and for level pointcloud without a cloud (field "cloud").
RegistrationResult register_map(slam::map::Map& map, const markers::MarkerMap& scan,
                                const Camera& camera, const RegisterOptions& options = {},
                                const render::PointCloud* cloud = nullptr,
                                const RefineProgress& progress = {});

// The result as one JSON document (level, transform, per-level residuals, per-marker figures,
// times): what `coloc register` stores in the map's metadata and prints with --json.
std::string registration_json(const RegistrationResult& result);

}  // namespace coloc::registration::align
