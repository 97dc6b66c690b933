#pragma once
// coloc::e57::Reader: opens an E57 file, parses its XML into the element tree and the plain model
// (scans = data3D, images = images2D), and reads points and image blobs on demand.
//
//   coloc::e57::Reader r("scan.e57");
//   for (std::size_t s = 0; s < r.scans().size(); ++s) {
//     coloc::e57::PointStream stream = r.open_points(s);   // all standard fields present
//     coloc::e57::PointBuffer chunk;                       // reused: no allocation per chunk
//     while (stream.read(chunk, 1 << 16) > 0) { use chunk.cartesian_x[i] ... }
//   }
//   for (std::size_t i = 0; i < r.images().size(); ++i) {
//     const auto& im = r.images()[i];                      // pinhole: focal_length, pose, ...
//     std::vector<std::uint8_t> jpeg_or_png = r.read_image(i);  // decode with cv::imdecode
//   }
//
// Thread-safety: a Reader is immutable after construction and every read opens its own file
// handle, so const member functions may be called from several threads. A PointStream is used by
// one thread at a time. Errors (bad file, CRC mismatch, broken structure) throw coloc::e57::Error
// naming the file, byte offsets / page and element path.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "e57io/element.hpp"
#include "e57io/paged_file.hpp"
#include "e57io/types.hpp"

namespace coloc::e57 {

struct ReaderOptions {
  ChecksumPolicy checksums;  // pages whose CRC is checked on every read (default: all)
  void check() const { checksums.check(); }
};

class CompressedVectorReader;
struct Sink;

// Reads one scan's points in chunks; memory is bounded by the chunk size (plus ~1 MiB of
// packet buffers), never by the scan.
class PointStream {
 public:
  PointStream(const std::filesystem::path& path, ChecksumPolicy checksums, const Element& points,
              std::uint32_t field_mask);
  ~PointStream();
  PointStream(PointStream&&) noexcept;
  PointStream& operator=(PointStream&&) noexcept;

  std::uint64_t point_count() const;
  std::uint64_t points_read() const;
  std::uint32_t field_mask() const { return mask_; }  // fields filled by read()

  // Replaces `buffer` with the next min(max_points, remaining) points; returns that count (0 at
  // the end). `buffer` keeps its capacity between calls.
  std::size_t read(PointBuffer& buffer, std::size_t max_points);

 private:
  std::unique_ptr<PagedReader> file_;
  std::unique_ptr<CompressedVectorReader> cv_;
  std::vector<int> channel_field_;  // PointField index per channel, -1 = not read
  std::vector<Sink> sinks_;
  std::uint32_t mask_ = 0;
};

// A row or column of a structured scan (data3D pointGroupingSchemes/groupingByLine).
struct LineGroup {
  std::int64_t id = 0;  // value of the idElementName field (row or column index)
  std::int64_t start_point = 0;
  std::int64_t point_count = 0;
};

class Reader {
 public:
  explicit Reader(const std::filesystem::path& path, ReaderOptions options = {});

  const std::filesystem::path& path() const { return path_; }
  const FileInfo& info() const { return info_; }
  const Element& root() const { return root_; }  // the whole element tree, extensions included
  const std::vector<Data3D>& scans() const { return scans_; }
  const std::vector<Image2D>& images() const { return images_; }

  // Streams scan `scan`'s points. field_mask selects fields (bits of field_bit()); 0 = every
  // standard field of the prototype. Requesting a field the scan lacks throws Error.
  PointStream open_points(std::size_t scan, std::uint32_t field_mask = 0) const;
  // Reads a whole scan into one buffer (convenience; memory grows with the scan).
  PointBuffer read_points(std::size_t scan, std::uint32_t field_mask = 0) const;
  // The scan's groupingByLine groups (empty if it has none).
  std::vector<LineGroup> read_line_groups(std::size_t scan) const;

  // The bytes of a blob (checks its 16-byte section header).
  std::vector<std::uint8_t> read_blob(const BlobRef& blob) const;
  // The encoded image (JPEG or PNG per images()[i].format) and its PNG mask (empty if none).
  std::vector<std::uint8_t> read_image(std::size_t image) const;
  std::vector<std::uint8_t> read_image_mask(std::size_t image) const;

  // Full check: every page CRC, every scan's points decoded, every blob header. Throws on the
  // first problem.
  void verify() const;

 private:
  const Element& points_element(std::size_t scan) const;

  std::filesystem::path path_;
  ReaderOptions options_;
  FileInfo info_;
  Element root_;
  std::vector<Data3D> scans_;
  std::vector<Image2D> images_;
};

}  // namespace coloc::e57
