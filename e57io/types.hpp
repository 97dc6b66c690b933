#pragma once
// Plain value types of the E57 model (ASTM E2807 sections 9-10): scans (data3D), images
// (images2D), poses and point buffers. Units as in the standard: metres, radians, seconds.
// These types are shared by the Reader (which fills them) and the Writer (which writes them).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace coloc::e57 {

// Unit quaternion (w, x, y, z), Hamilton convention as in E57. Files may hold non-unit
// quaternions; they are returned as stored.
struct Quaternion {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
};

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

// E57 rigidBodyTransform. For a scan or image it maps local coordinates into the file-level
// frame: parent_from_local (e.g. world_from_scan, world_from_camera). p_parent = R * p + t.
struct Pose {
  Quaternion rotation;
  Vec3 translation;
};

// Date/time as GPS seconds (E57 dateTimeValue) and whether an atomic clock referenced it.
struct DateTime {
  double gps_seconds = 0.0;
  bool atomic_clock_referenced = false;
};

struct CartesianBounds {
  double x_min = 0, x_max = 0, y_min = 0, y_max = 0, z_min = 0, z_max = 0;
};
struct SphericalBounds {
  double range_min = 0, range_max = 0, elevation_min = 0, elevation_max = 0;
  double azimuth_start = 0, azimuth_end = 0;
};
struct IndexBounds {
  std::int64_t row_min = 0, row_max = 0, column_min = 0, column_max = 0;
  std::int64_t return_min = 0, return_max = 0;
};
struct IntensityLimits {
  double minimum = 0, maximum = 0;
};
struct ColorLimits {
  double red_min = 0, red_max = 0, green_min = 0, green_max = 0, blue_min = 0, blue_max = 0;
};

// The standard per-point fields of a data3D prototype.
enum class PointField : std::uint8_t {
  kCartesianX,
  kCartesianY,
  kCartesianZ,
  kCartesianInvalidState,  // 0 valid, 1 direction only, 2 invalid
  kSphericalRange,
  kSphericalAzimuth,
  kSphericalElevation,
  kSphericalInvalidState,
  kIntensity,
  kIsIntensityInvalid,
  kColorRed,
  kColorGreen,
  kColorBlue,
  kIsColorInvalid,
  kRowIndex,
  kColumnIndex,
  kReturnIndex,
  kReturnCount,
  kTimeStamp,
  kIsTimeStampInvalid,
};
inline constexpr std::size_t kPointFieldCount = 20;

// The E57 element name of a field ("cartesianX"), and back (nullopt for non-standard names).
const char* field_name(PointField field);
std::optional<PointField> field_from_name(const std::string& name);

// How one prototype field is encoded in the file.
enum class FieldKind : std::uint8_t { kInteger, kScaledInteger, kFloat };

struct FieldSpec {
  PointField field = PointField::kCartesianX;
  FieldKind kind = FieldKind::kFloat;
  std::int64_t minimum = 0;  // Integer/ScaledInteger: raw value range (sets the bit width)
  std::int64_t maximum = 0;
  double scale = 1.0;  // ScaledInteger: value = raw * scale + offset
  double offset = 0.0;
  bool single_precision = false;  // Float

  static FieldSpec integer(PointField f, std::int64_t min, std::int64_t max);
  // Values in [min_value, max_value] stored as round((v - offset) / scale).
  static FieldSpec scaled(PointField f, double scale, double min_value, double max_value,
                          double offset = 0.0);
  static FieldSpec float64(PointField f);
  static FieldSpec float32(PointField f);
};

// One prototype entry as found in a file (standard or extension).
struct PrototypeField {
  std::string name;                 // element name, with prefix for extensions ("nor:normalX")
  std::optional<PointField> field;  // set for standard fields
  FieldSpec spec;                   // .field meaningful only when `field` is set
};

// Points as a struct of arrays. Only the vectors of fields that are present() are filled; each
// present vector has size() elements. Colour and intensity keep the file's values (see the
// scan's colorLimits / intensityLimits for their range). Row/column/return indices must fit in
// int32 (checked against the prototype's range when a stream is opened).
struct PointBuffer {
  std::size_t size = 0;
  std::uint32_t present_mask = 0;  // bit i set when PointField(i) is present

  std::vector<double> cartesian_x, cartesian_y, cartesian_z;  // metres
  std::vector<std::int8_t> cartesian_invalid_state;
  std::vector<double> spherical_range, spherical_azimuth, spherical_elevation;  // m, rad, rad
  std::vector<std::int8_t> spherical_invalid_state;
  std::vector<float> intensity;
  std::vector<std::int8_t> is_intensity_invalid;
  std::vector<float> color_red, color_green, color_blue;
  std::vector<std::int8_t> is_color_invalid;
  std::vector<std::int32_t> row_index, column_index, return_index, return_count;
  std::vector<double> time_stamp;  // seconds
  std::vector<std::int8_t> is_time_stamp_invalid;

  bool present(PointField f) const { return (present_mask >> static_cast<unsigned>(f)) & 1u; }
  // Marks `fields` present (others absent) and resizes their vectors to n points.
  void reset(std::uint32_t mask, std::size_t n);
  // Appends point i of `other` (same present_mask) to this buffer; for small tools and tests.
  void append(const PointBuffer& other, std::size_t i);
};

inline constexpr std::uint32_t field_bit(PointField f) {
  return 1u << static_cast<unsigned>(f);
}

struct GroupingByLine {
  std::string id_element_name;  // "rowIndex" or "columnIndex"
  std::uint64_t group_count = 0;
};

// One data3D entry (a scan). Optional members are absent in the file when nullopt.
struct Data3D {
  std::string guid;
  std::string name, description;
  std::string sensor_vendor, sensor_model, sensor_serial_number;
  std::string sensor_hardware_version, sensor_software_version, sensor_firmware_version;
  std::optional<double> temperature, relative_humidity, atmospheric_pressure;
  std::optional<DateTime> acquisition_start, acquisition_end;
  std::optional<Pose> pose;  // world_from_scan
  std::optional<CartesianBounds> cartesian_bounds;
  std::optional<SphericalBounds> spherical_bounds;
  std::optional<IndexBounds> index_bounds;
  std::optional<IntensityLimits> intensity_limits;
  std::optional<ColorLimits> color_limits;
  std::vector<std::string> original_guids;
  std::optional<GroupingByLine> grouping_by_line;

  // Filled by the reader (ignored by the writer, which derives them).
  std::uint64_t point_count = 0;
  std::vector<PrototypeField> prototype;
  std::uint32_t field_mask = 0;  // standard fields present in the prototype
  std::string element_path;      // "/data3D/0"
};

enum class ImageRepresentation : std::uint8_t {
  kVisualReference,
  kPinhole,
  kSpherical,
  kCylindrical
};
enum class ImageFormat : std::uint8_t { kJpeg, kPng };

const char* to_string(ImageRepresentation r);

// Location of a blob's bytes: the physical offset of its 16-byte section header and its length.
struct BlobRef {
  std::uint64_t file_offset = 0;
  std::uint64_t length = 0;
};

// One images2D entry. Pixel sizes and focal length are in metres (E57 convention); principal
// point in pixels.
struct Image2D {
  std::string guid;
  std::string name, description;
  std::string sensor_vendor, sensor_model, sensor_serial_number;
  std::string associated_data3d_guid;
  std::optional<DateTime> acquisition_time;
  std::optional<Pose> pose;  // world_from_camera

  ImageRepresentation representation = ImageRepresentation::kPinhole;
  ImageFormat format = ImageFormat::kJpeg;
  std::int64_t width = 0, height = 0;            // pixels
  double pixel_width = 0.0, pixel_height = 0.0;  // metres (spherical: radians)
  double focal_length = 0.0;                     // pinhole, metres
  double principal_point_x = 0.0;                // pinhole, pixels
  double principal_point_y = 0.0;                // pinhole and cylindrical, pixels
  double radius = 0.0;                           // cylindrical, metres

  // Filled by the reader.
  BlobRef image;                // jpegImage or pngImage
  std::optional<BlobRef> mask;  // imageMask (PNG)
  std::string element_path;     // "/images2D/0"
};

// File-level metadata.
struct FileInfo {
  std::uint32_t version_major = 1, version_minor = 0;
  std::string guid;
  std::string library_version;
  std::string coordinate_metadata;
  std::optional<DateTime> creation_time;
  std::uint64_t physical_length = 0;
};

}  // namespace coloc::e57
