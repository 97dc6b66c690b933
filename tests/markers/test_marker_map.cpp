// Marker map file: round trip in YAML and JSON, and errors that name the offending field.

#include <gtest/gtest.h>

#include <fstream>

#include "markers/detector.hpp"
#include "markers/dictionary.hpp"
#include "markers/marker_map.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::markers {
namespace {

MarkerMap sample_map() {
  MarkerMap map;
  map.dictionary = "DICT_APRILTAG_36h11";
  map.source = "room scan.e57";
  map.images = {"scan0/+x", "scan0/-y", "scan1/pinhole 3"};
  MapMarker m;
  m.id = 12;
  m.edge_length = 0.1675;
  // A marker on the wall x = 2 facing -x: its right is -y... any right-handed square will do.
  const double h = 0.1675 / 2;
  m.corners = {Eigen::Vector3d(2.0, 1.0 + h, 1.5 + h), Eigen::Vector3d(2.0, 1.0 - h, 1.5 + h),
               Eigen::Vector3d(2.0, 1.0 - h, 1.5 - h), Eigen::Vector3d(2.0, 1.0 + h, 1.5 - h)};
  m.sightings = 3;
  m.rejected_sightings = 1;
  m.ambiguous_sightings = 2;
  m.residual = 0.00123456789;
  m.images = {"scan0/+x", "scan1/pinhole 3"};
  map.markers[m.id] = m;
  m.id = 3;
  m.images.clear();
  for (auto& c : m.corners)
    c += Eigen::Vector3d(0.1234567891234, -7.0, 0.0);
  map.markers[m.id] = m;
  return map;
}

void expect_equal(const MarkerMap& a, const MarkerMap& b) {
  EXPECT_EQ(a.dictionary, b.dictionary);
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.images, b.images);
  ASSERT_EQ(a.markers.size(), b.markers.size());
  for (const auto& [id, ma] : a.markers) {
    const MapMarker& mb = b.markers.at(id);
    EXPECT_EQ(ma.id, mb.id);
    EXPECT_DOUBLE_EQ(ma.edge_length, mb.edge_length);
    for (int c = 0; c < 4; ++c)
      EXPECT_LT((ma.corners[c] - mb.corners[c]).norm(), 1e-12);
    EXPECT_EQ(ma.sightings, mb.sightings);
    EXPECT_EQ(ma.rejected_sightings, mb.rejected_sightings);
    EXPECT_EQ(ma.ambiguous_sightings, mb.ambiguous_sightings);
    EXPECT_DOUBLE_EQ(ma.residual, mb.residual);
    EXPECT_EQ(ma.images, mb.images);
  }
}

TEST(MarkerMap, RoundTripYamlAndJson) {
  const auto dir = coloc::testing::temp_dir("markers_map_roundtrip");
  const MarkerMap map = sample_map();
  for (const char* name : {"map.yaml", "map.json"}) {
    write_marker_map(dir / name, map);
    expect_equal(map, read_marker_map(dir / name));
  }
  MarkerMap empty;
  empty.dictionary = "DICT_4X4_50";
  write_marker_map(dir / "empty.yaml", empty);
  EXPECT_TRUE(read_marker_map(dir / "empty.yaml").markers.empty());
}

TEST(MarkerMap, GeometryHelpers) {
  const MapMarker m = sample_map().markers.at(12);
  EXPECT_LT((m.centre() - Eigen::Vector3d(2.0, 1.0, 1.5)).norm(), 1e-12);
  // Corner order 0 -> 1 runs along -y, 3 -> 0 along +z: the face points along -x.
  EXPECT_LT((m.normal() - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-12);
}

std::string error_field_of(const std::filesystem::path& path, const std::string& text) {
  {
    std::ofstream out(path);
    out << text;
  }
  try {
    read_marker_map(path);
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, path.string());
    return e.context().field;
  }
  ADD_FAILURE() << "accepted: " << text;
  return {};
}

TEST(MarkerMap, ErrorsNameTheField) {
  const auto dir = coloc::testing::temp_dir("markers_map_errors");
  const auto p = dir / "bad.yaml";
  const std::string head =
      "%YAML:1.0\n---\nformat: coloc-marker-map\nversion: 1\ndictionary: DICT_4X4_50\n";
  const std::string corners = "corners: [0,0,0, 1,0,0, 1,1,0, 0,1,0]";
  EXPECT_EQ(error_field_of(p, "%YAML:1.0\n---\nformat: other\nversion: 1\n"), "format");
  EXPECT_EQ(error_field_of(p, head + "markers: []\ncolour: red\n"), "colour");
  EXPECT_EQ(error_field_of(p, head), "markers");
  EXPECT_EQ(error_field_of(p, head + "markers:\n  - { id: 1, edge_length: 0.1 }\n"),
            "markers[0].corners");
  EXPECT_EQ(
      error_field_of(p, head + "markers:\n  - { id: 1, edge_length: 0.1, corners: [1,2,3] }\n"),
      "markers[0].corners");
  EXPECT_EQ(error_field_of(p, head + "markers:\n  - { id: 1, edge_length: -1, " + corners + " }\n"),
            "markers[0].edge_length");
  EXPECT_EQ(error_field_of(
                p, head + "markers:\n  - { id: 1, edge_length: 0.1, " + corners + ", size: 3 }\n"),
            "markers[0].size");
  EXPECT_EQ(error_field_of(p, head + "markers:\n  - { id: 1, edge_length: 0.1, " + corners +
                                  " }\n  - { id: 1, edge_length: 0.1, " + corners + " }\n"),
            "markers[1]");
  EXPECT_THROW(read_marker_map(dir / "missing.yaml"), Error);
}

// A NaN or infinite corner is an error naming the marker (register used to drop that marker as
// an outlier and write its output).
TEST(MarkerMap, NonFiniteCornersAreAnErrorNamingTheMarker) {
  const auto dir = coloc::testing::temp_dir("markers_map_nan");
  const auto p = dir / "nan.yaml";
  const std::string head =
      "%YAML:1.0\n---\nformat: coloc-marker-map\nversion: 1\ndictionary: DICT_4X4_50\n"
      "markers:\n  - { id: 3, edge_length: 0.1, corners: [0,0,0, 1,0,0, 1,1,0, 0,1,0] }\n";
  for (const std::string value : {".nan", ".inf", "-.inf"}) {
    {
      std::ofstream out(p);
      out << head << "  - { id: 7, edge_length: 0.1, corners: [0,0,0, 1,0,0, 1," << value
          << ",0, 0,1,0] }\n";
    }
    try {
      read_marker_map(p);
      ADD_FAILURE() << value << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, "markers[1].corners[7]") << value;
      EXPECT_NE(e.message().find("marker 7"), std::string::npos) << e.message();
    }
  }
}

// The input OpenCV 4.6's YAML reader loops forever on is refused at once (the YAML guard of
// slam/core), the line named.
TEST(MarkerMap, YamlThatHangsOpenCvIsRefused) {
  const auto p = coloc::testing::temp_dir("markers_map_loop") / "loop.yaml";
  std::ofstream(p) << "%YAML:1.0\n---\nformat: coloc-marker-map\n----x\n";
  try {
    read_marker_map(p);
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 4);
  }
}

// Inputs scripts/fuzz_yaml found, on which OpenCV's parser lets std::length_error out or asserts
// (isMap() on a document that is no map): each reader turns them into an Error naming the file.
TEST(MarkerFiles, WhatOpenCvThrowsIsAnErrorNamingTheFile) {
  const auto dir = coloc::testing::temp_dir("marker_files_fuzz");
  const auto expect_named = [&](const std::string& name, const std::string& text, auto read) {
    const auto path = dir / name;
    std::ofstream(path, std::ios::binary) << text;
    try {
      read(path);
      FAIL() << name << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.context().file, path.string()) << e.what();
    } catch (const std::exception& e) {
      FAIL() << name << ": " << e.what() << " (not a coloc::Error)";
    }
  };
  expect_named("map.yaml",
               "%YAML:1.0\n---\nformat: coloc-marker-map\nversion: 1\ndictixnar0,0, 1,\xc1,0, "
               "0y: DICT_4X4_50\nmarkers:\n  - { id: 3, edge_length: 0.1, :1.0\n--)\nf0orMat: "
               "coloc-marker-map\nversi\n",
               [](const auto& p) { read_marker_map(p); });
  expect_named("dictionary.yml", "%YAML:1.0\n--2222222222222222222222222222222222222",
               [](const auto& p) { make_dictionary(p.string()); });
  expect_named("params.yml", "%YAML:1.0nSizeMin:0\n-(--SizeMi", [](const auto& p) {
    auto parameters = cv::aruco::DetectorParameters::create();
    read_detector_parameters(p, *parameters);
  });
}

}  // namespace
}  // namespace coloc::markers
