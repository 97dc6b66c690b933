#include "e57io/reader.hpp"

#include <algorithm>
#include <limits>

#include "e57io/bytes.hpp"
#include "e57io/compressed_vector.hpp"
#include "e57io/model.hpp"
#include "e57io/point_access.hpp"

namespace coloc::e57 {
namespace {

// The sink type of a field must be able to hold every value its prototype allows.
void check_field_range(const Codec& codec, PointField field, const std::string& name,
                       const std::string& file, const std::string& path) {
  Sink::Type type = Sink::Type::kNone;
  PointBuffer probe;
  probe.reset(field_bit(field), 0);
  type = sink_for(probe, field).type;
  if (type != Sink::Type::kInt8 && type != Sink::Type::kInt32) return;
  const std::int64_t lo = type == Sink::Type::kInt8 ? std::numeric_limits<std::int8_t>::min()
                                                    : std::numeric_limits<std::int32_t>::min();
  const std::int64_t hi = type == Sink::Type::kInt8 ? std::numeric_limits<std::int8_t>::max()
                                                    : std::numeric_limits<std::int32_t>::max();
  const bool fits = codec.kind == FieldKind::kInteger && codec.minimum >= lo &&
                    codec.range <= static_cast<std::uint64_t>(hi - codec.minimum);
  if (!fits) {
    throw Error("field '" + name + "' must be an Integer within [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "]",
                {.file = file, .element = path});
  }
}

}  // namespace

PointStream::PointStream(const std::filesystem::path& path, ChecksumPolicy checksums,
                         const Element& points, std::uint32_t field_mask)
    : file_(std::make_unique<PagedReader>(path, checksums)),
      cv_(std::make_unique<CompressedVectorReader>(*file_, points)) {
  std::uint32_t available = 0;
  const auto& names = cv_->channel_names();
  channel_field_.assign(names.size(), -1);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto f = field_from_name(names[i]);
    if (!f || (available & field_bit(*f))) continue;  // extension field or duplicate: skipped
    available |= field_bit(*f);
    if (field_mask == 0 || (field_mask & field_bit(*f))) {
      check_field_range(cv_->channel_codec(i), *f, names[i], file_->path(), points.path);
      channel_field_[i] = static_cast<int>(*f);
    }
  }
  if (field_mask != 0 && (field_mask & ~available) != 0) {
    for (std::size_t k = 0; k < kPointFieldCount; ++k) {
      if ((field_mask & ~available) & (1u << k)) {
        throw Error(
            std::string("scan has no field '") + field_name(static_cast<PointField>(k)) + "'",
            {.file = file_->path(), .element = points.path});
      }
    }
  }
  mask_ = field_mask == 0 ? available : field_mask;
}

PointStream::~PointStream() = default;
PointStream::PointStream(PointStream&&) noexcept = default;
PointStream& PointStream::operator=(PointStream&&) noexcept = default;

std::uint64_t PointStream::point_count() const {
  return cv_->record_count();
}
std::uint64_t PointStream::points_read() const {
  return cv_->records_read();
}

std::size_t PointStream::read(PointBuffer& buffer, std::size_t max_points) {
  const auto n = static_cast<std::size_t>(
      std::min<std::uint64_t>(max_points, cv_->record_count() - cv_->records_read()));
  buffer.reset(mask_, n);
  if (n == 0) return 0;
  std::vector<Sink>& sinks = sinks_;  // kept between calls: no allocation per chunk
  sinks.assign(channel_field_.size(), Sink{});
  for (std::size_t i = 0; i < sinks.size(); ++i) {
    if (channel_field_[i] >= 0)
      sinks[i] = sink_for(buffer, static_cast<PointField>(channel_field_[i]));
  }
  return cv_->read(n, sinks);
}

Reader::Reader(const std::filesystem::path& path, ReaderOptions options)
    : path_(path), options_(options) {
  options_.check();
  PagedReader file(path, options_.checksums);
  const FileHeader& h = file.header();
  std::string xml(static_cast<std::size_t>(h.xml_logical_length), '\0');
  file.read(physical_to_logical(h.xml_physical_offset),
            {reinterpret_cast<std::uint8_t*>(xml.data()), xml.size()});
  root_ = parse_xml(xml, file.path());
  try {
    info_ = file_info_from_element(root_);
    info_.physical_length = h.physical_length;
    if (const Element* d = root_.find("data3D")) {
      if (d->type != ElementType::kVector)
        throw Error("data3D is not a Vector", {.element = d->path});
      for (const Element& s : d->children)
        scans_.push_back(data3d_from_element(s));
    }
    if (const Element* im = root_.find("images2D")) {
      if (im->type != ElementType::kVector)
        throw Error("images2D is not a Vector", {.element = im->path});
      for (const Element& i : im->children)
        images_.push_back(image2d_from_element(i));
    }
  } catch (const Error& e) {
    ErrorContext ctx = e.context();
    ctx.file = file.path();
    throw Error(e.message(), ctx);
  }
}

const Element& Reader::points_element(std::size_t scan) const {
  if (scan >= scans_.size()) {
    throw Error("scan index " + std::to_string(scan) + " out of range (file has " +
                    std::to_string(scans_.size()) + ")",
                {.file = path_.string()});
  }
  return *root_.find("data3D")->children[scan].find("points");  // checked when parsed
}

PointStream Reader::open_points(std::size_t scan, std::uint32_t field_mask) const {
  return PointStream(path_, options_.checksums, points_element(scan), field_mask);
}

PointBuffer Reader::read_points(std::size_t scan, std::uint32_t field_mask) const {
  PointStream stream = open_points(scan, field_mask);
  PointBuffer all;
  if (stream.point_count() > (std::uint64_t{1} << 31)) {
    throw Error("scan has " + std::to_string(stream.point_count()) +
                    " points: too many for read_points(), stream them with open_points()",
                {.file = path_.string(), .element = scans_[scan].element_path});
  }
  all.reset(stream.field_mask(), static_cast<std::size_t>(stream.point_count()));
  // Decode straight into the final buffer, chunk by chunk (no copies).
  auto file = std::make_unique<PagedReader>(path_, options_.checksums);
  CompressedVectorReader cv(*file, points_element(scan));
  std::vector<Sink> sinks(cv.channel_count());
  std::size_t done = 0;
  constexpr std::size_t kChunk = 1 << 16;
  while (done < all.size) {
    for (std::size_t i = 0; i < sinks.size(); ++i) {
      const auto f = field_from_name(cv.channel_names()[i]);
      if (f && all.present(*f)) sinks[i] = sink_for(all, *f, done);
    }
    const std::size_t n = cv.read(std::min(kChunk, all.size - done), sinks);
    if (n == 0) break;
    done += n;
  }
  return all;
}

std::vector<LineGroup> Reader::read_line_groups(std::size_t scan) const {
  points_element(scan);  // range check
  const Element* groups =
      root_.find("data3D")->children[scan].find_path("pointGroupingSchemes/groupingByLine/groups");
  std::vector<LineGroup> out;
  if (groups == nullptr || groups->type != ElementType::kCompressedVector) return out;
  PagedReader file(path_, options_.checksums);
  CompressedVectorReader cv(file, *groups);
  out.resize(static_cast<std::size_t>(std::min<std::uint64_t>(cv.record_count(), 1u << 24)));
  std::vector<std::int64_t> id(out.size()), start(out.size()), count(out.size());
  std::vector<Sink> sinks(cv.channel_count());
  for (std::size_t i = 0; i < sinks.size(); ++i) {
    const std::string& n = cv.channel_names()[i];
    if (n == "idElementValue") sinks[i] = {Sink::Type::kInt64, id.data()};
    if (n == "startPointIndex") sinks[i] = {Sink::Type::kInt64, start.data()};
    if (n == "pointCount") sinks[i] = {Sink::Type::kInt64, count.data()};
  }
  const std::size_t n = cv.read(out.size(), sinks);
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out[i] = {id[i], start[i], count[i]};
  return out;
}

std::vector<std::uint8_t> Reader::read_blob(const BlobRef& blob) const {
  PagedReader file(path_, options_.checksums);
  const std::uint64_t at = physical_to_logical(blob.file_offset);
  if (blob.file_offset % kPageSize >= kPageData || blob.file_offset < kHeaderSize ||
      at + 16 > file.logical_length() || blob.length > file.logical_length() - at - 16) {
    throw Error("blob (offset " + std::to_string(blob.file_offset) + ", length " +
                    std::to_string(blob.length) + ") lies outside the file",
                {.file = file.path(), .physical_offset = blob.file_offset});
  }
  std::uint8_t head[16];
  file.read(at, head);
  const std::uint64_t section_length = load_le<std::uint64_t>(head + 8);
  if (head[0] != 0 || section_length < 16 + blob.length) {
    throw file.error_at("invalid blob section header (id " + std::to_string(head[0]) +
                            ", section length " + std::to_string(section_length) + ")",
                        at);
  }
  std::vector<std::uint8_t> out(static_cast<std::size_t>(blob.length));
  file.read(at + 16, out);
  return out;
}

std::vector<std::uint8_t> Reader::read_image(std::size_t image) const {
  return read_blob(images_.at(image).image);
}

std::vector<std::uint8_t> Reader::read_image_mask(std::size_t image) const {
  const auto& m = images_.at(image).mask;
  return m ? read_blob(*m) : std::vector<std::uint8_t>{};
}

void Reader::verify() const {
  {
    PagedReader file(path_, ChecksumPolicy::none());
    file.verify_all_pages();
  }
  for (std::size_t s = 0; s < scans_.size(); ++s) {
    PointStream stream = open_points(s);
    PointBuffer chunk;
    while (stream.read(chunk, 1 << 16) > 0) {
    }
    read_line_groups(s);
  }
  for (std::size_t i = 0; i < images_.size(); ++i) {
    read_image(i);
    read_image_mask(i);
  }
}

}  // namespace coloc::e57
