#pragma once
// coloc::e57::Writer: writes a standard E57 file (ASTM E2807): scans (data3D) with bit-packed
// points and images (images2D) with JPEG/PNG blobs and poses. Binary sections are streamed to the
// file as they come; the XML section and the file header are written by close().
//
//   coloc::e57::Writer w("out.e57");
//   coloc::e57::Data3D scan;  scan.name = "station 1";  scan.pose = world_from_scan;
//   w.begin_scan(scan, {FieldSpec::scaled(PointField::kCartesianX, 1e-4, -100, 100), ...,
//                       FieldSpec::integer(PointField::kColorRed, 0, 255), ...});
//   w.add_points(chunk);                       // any number of times; fields as declared
//   w.end_scan();
//   coloc::e57::Image2D im;  im.representation = ImageRepresentation::kPinhole;  im.pose = ...;
//   im.width = 2048; im.height = 2048; im.focal_length = ...; im.pixel_width = ...;
//   w.add_image(im, jpeg_bytes);
//   w.close();
//
// The writer derives per scan: guid (if empty), cartesianBounds / sphericalBounds / indexBounds
// (from the points, if not given), intensityLimits / colorLimits (from the field ranges, if not
// given). Not thread-safe. Throws coloc::e57::Error naming the file and field on bad input.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "e57io/element.hpp"
#include "e57io/error.hpp"
#include "e57io/types.hpp"

namespace coloc::e57 {

struct WriterOptions {
  std::string guid;                 // file guid; generated when empty
  std::string coordinate_metadata;  // e.g. a WKT or EPSG string; empty = not written
  std::optional<DateTime> creation_time;
  std::string library_version = "coloc-e57io";
  // Extension namespaces (prefix, uri) declared on the root, for extension fields you add to
  // the tree through extra_root_children.
  std::vector<std::pair<std::string, std::string>> namespaces;
  std::vector<Element> extra_root_children;
  void check() const;
};

class CompressedVectorWriter;
class PagedWriter;

class Writer {
 public:
  explicit Writer(const std::filesystem::path& path, WriterOptions options = {});
  // Without close() the file stays incomplete (no valid header) and is removed.
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Starts a scan whose points have exactly `fields` (each standard field at most once;
  // cartesian X/Y/Z together). One scan is open at a time.
  void begin_scan(const Data3D& header, const std::vector<FieldSpec>& fields);
  // Appends points; `points` must have every declared field present.
  void add_points(const PointBuffer& points);
  // Finishes the open scan; returns its index in data3D.
  std::size_t end_scan();
  // begin_scan + add_points + end_scan.
  std::size_t write_scan(const Data3D& header, const std::vector<FieldSpec>& fields,
                         const PointBuffer& points);

  // Adds an image with its encoded bytes (JPEG or PNG per image.format) and an optional PNG
  // mask. Returns its index in images2D. Not allowed while a scan is open.
  std::size_t add_image(const Image2D& image, std::span<const std::uint8_t> encoded,
                        std::span<const std::uint8_t> mask = {});

  // Writes the XML and header. Returns the file length in bytes.
  std::uint64_t close();

 private:
  struct OpenScan;
  Error error(const std::string& message, const std::string& element = {}) const;
  BlobRef write_blob(std::span<const std::uint8_t> bytes);

  std::string path_;
  WriterOptions options_;
  std::unique_ptr<PagedWriter> file_;
  std::unique_ptr<OpenScan> scan_;
  Element data3d_;
  Element images2d_;
  bool closed_ = false;
};

// A random RFC 4122 style guid "{XXXXXXXX-XXXX-4XXX-YXXX-XXXXXXXXXXXX}" (std::random_device).
std::string make_guid();

}  // namespace coloc::e57
