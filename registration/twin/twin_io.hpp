#pragma once
// Text outputs of the twin generator (private to coloc_twin): ORB-SLAM3 settings, IMU files,
// ground-truth tables. All numbers with enough digits to round-trip.

#include <filesystem>
#include <string>
#include <vector>

#include "registration/twin/motion.hpp"
#include "registration/twin/scan.hpp"
#include "registration/twin/scene.hpp"
#include "registration/twin/sensor_noise.hpp"
#include "slam/core/camera.hpp"

namespace coloc::registration::twin::io {

// An ORB-SLAM3 (v1.0 format) RGB-D(-inertial) settings file for the twin's camera.
// ORB-SLAM3 settings of the twin's camera, with coloc's Markers.dictionary (OpenCV's numeric
// id, as markers::make_dictionary reads it) and Markers.size, so SLAM looks for the twin's markers.
void write_camera_settings(const std::filesystem::path& path, const PinholeCamera& camera,
                           double fps, const DepthNoiseOptions& depth, const ImuOptions& imu,
                           int marker_dictionary, double marker_size);
void write_imu(const std::filesystem::path& path, const std::vector<ImuSample>& samples);
void write_imu_truth(const std::filesystem::path& path, const std::vector<ImuTruth>& truth);
void write_headset_calibration(const std::filesystem::path& path, const HeadsetOptions& options,
                               const SE3& world_from_xr_start);
void write_markers(const std::filesystem::path& corners_path,
                   const std::filesystem::path& poses_path, const std::vector<MarkerTruth>& markers,
                   int dictionary);
void write_stations(const std::filesystem::path& stations_path,
                    const std::filesystem::path& faces_path,
                    const std::vector<ScanStation>& stations);

// "t tx ty tz qx qy qz qw" with a leading comment line.
std::string tum_line(double t, const SE3& pose);

}  // namespace coloc::registration::twin::io
