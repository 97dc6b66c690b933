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
#include "registration/align/surface_ba.hpp"

namespace coloc::registration::align {

// kSurface: markers, then the global BA against the scan's surface with the kept markers'
// corners as terms too (surface_ba.hpp): markers and surface together.
enum class Level { kRough, kMarkers, kPointcloud, kSurface };
const char* level_name(Level level);
// "rough", "markers", "pointcloud" or "surface"; throws coloc::Error (field "level") otherwise.
Level parse_level(const std::string& name);

struct RegisterOptions {
  Level level = Level::kMarkers;
  SlamMarkerOptions corners;
  RoughOptions rough;
  MarkerBaOptions ba;
  RefineOptions refine;                // level pointcloud
  ScanSurfaceOptions scan_surface;     // level surface
  SurfaceBaOptions surface;            // level surface
  double ba_max_rough_residual = 1.0;  // metres (see the header)
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct RegistrationResult {
  Level level = Level::kRough;
  SlamMarkers slam_markers;
  RoughAlignment rough;
  std::optional<MarkerBaReport> ba;        // levels markers and pointcloud
  std::optional<RefineReport> refine;      // level pointcloud
  std::optional<SurfaceBaReport> surface;  // level surface
  // The rigid (similarity) part: rough alignment's transform. The BA then deforms the map, so
  // no single transform maps the input onto the output at level markers.
  Sim3 scan_from_slam;
  double ms_corners = 0.0, ms_rough = 0.0, ms_ba = 0.0, ms_refine = 0.0, ms_surface = 0.0;
};

// Registers `map` in place. Levels pointcloud and surface need `cloud` (the scan's points,
// scan_cloud.hpp): pointcloud refines after the marker BA (refine.hpp; `progress` reports its
// keyframes), surface bends the map onto the scan's surface with the markers kept by the marker
// BA, using `depth` (the keyframes' depth samples; null or empty: map points only). Throws
// coloc::Error from rough alignment (too few or inconsistent markers, naming them), for invalid
// options, and for levels pointcloud and surface without a cloud (field "cloud").
RegistrationResult register_map(slam::map::Map& map, const markers::MarkerMap& scan,
                                const Camera& camera, const RegisterOptions& options = {},
                                const render::PointCloud* cloud = nullptr,
                                const RefineProgress& progress = {},
                                const KeyframeDepthSamples* depth = nullptr);

// The result as one JSON document (level, transform, per-level residuals, per-marker figures,
// times): what `coloc register` stores in the map's metadata and prints with --json.
std::string registration_json(const RegistrationResult& result);

}  // namespace coloc::registration::align
