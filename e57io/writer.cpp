#include "e57io/writer.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "e57io/bytes.hpp"
#include "e57io/compressed_vector_writer.hpp"
#include "e57io/model.hpp"
#include "e57io/paged_file.hpp"
#include "e57io/point_access.hpp"

namespace coloc::e57 {
namespace {

Element vector_element(const std::string& name) {
  Element v;
  v.name = name;
  v.type = ElementType::kVector;
  v.allow_heterogeneous = true;
  return v;
}

Element prototype_element(const FieldSpec& spec) {
  Element e;
  e.name = field_name(spec.field);
  switch (spec.kind) {
    case FieldKind::kInteger:
      e.type = ElementType::kInteger;
      break;
    case FieldKind::kScaledInteger:
      e.type = ElementType::kScaledInteger;
      break;
    case FieldKind::kFloat:
      e.type = ElementType::kFloat;
      break;
  }
  e.int_minimum = spec.minimum;
  e.int_maximum = spec.maximum;
  // A prototype element's own value is never used, but libE57Format rejects one outside
  // [minimum, maximum]; the default 0 may be.
  e.int_value = std::clamp<std::int64_t>(0, spec.minimum, spec.maximum);
  e.scale = spec.scale;
  e.offset = spec.offset;
  e.single_precision = spec.single_precision;
  const double lim = spec.single_precision ? FLT_MAX : DBL_MAX;
  e.float_minimum = -lim;
  e.float_maximum = lim;
  return e;
}

double spec_value(const FieldSpec& s, std::int64_t raw) {
  return s.kind == FieldKind::kScaledInteger ? static_cast<double>(raw) * s.scale + s.offset
                                             : static_cast<double>(raw);
}

struct MinMax {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
};

}  // namespace

std::string make_guid() {
  std::random_device rd;
  std::mt19937_64 rng((std::uint64_t{rd()} << 32) ^ rd());
  const std::uint64_t a = rng();
  const std::uint64_t b = rng();
  char buf[48];
  std::snprintf(buf, sizeof buf, "{%08X-%04X-4%03X-%04X-%012llX}", static_cast<unsigned>(a >> 32),
                static_cast<unsigned>((a >> 16) & 0xFFFF), static_cast<unsigned>(a & 0xFFF),
                static_cast<unsigned>(0x8000 | ((b >> 48) & 0x3FFF)),
                static_cast<unsigned long long>(b & 0xFFFFFFFFFFFFull));
  return buf;
}

void WriterOptions::check() const {
  for (const auto& [prefix, uri] : namespaces) {
    if (prefix.empty() || uri.empty()) throw Error("extension namespace needs a prefix and a uri");
  }
}

struct Writer::OpenScan {
  Data3D header;
  std::vector<FieldSpec> fields;
  std::unique_ptr<CompressedVectorWriter> cv;
  std::vector<std::vector<double>> doubles;
  std::vector<std::vector<std::int64_t>> integers;
  MinMax x, y, z, range, azimuth, elevation, row, column, ret, intensity, red, green, blue;
};

Writer::Writer(const std::filesystem::path& path, WriterOptions options)
    : path_(path.string()), options_(std::move(options)) {
  options_.check();
  file_ = std::make_unique<PagedWriter>(path);
  data3d_ = vector_element("data3D");
  images2d_ = vector_element("images2D");
}

Writer::~Writer() {
  if (!closed_) {
    file_.reset();
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
}

Error Writer::error(const std::string& message, const std::string& element) const {
  return Error(message, {.file = path_, .element = element});
}

void Writer::begin_scan(const Data3D& header, const std::vector<FieldSpec>& fields) {
  if (closed_) throw error("writer is closed");
  if (scan_) throw error("begin_scan while another scan is open");
  const std::string where = "/data3D/" + std::to_string(data3d_.children.size());
  if (fields.empty()) throw error("a scan needs at least one point field", where);
  std::uint32_t mask = 0;
  std::vector<Codec> codecs;
  for (const FieldSpec& f : fields) {
    const std::string name = field_name(f.field);
    if (mask & field_bit(f.field)) throw error("field '" + name + "' declared twice", where);
    mask |= field_bit(f.field);
    if (f.kind != FieldKind::kFloat && f.minimum > f.maximum) {
      throw error("field '" + name + "' has minimum > maximum", where);
    }
    if (f.kind == FieldKind::kScaledInteger && !(f.scale > 0.0 && std::isfinite(f.scale))) {
      throw error("field '" + name + "' needs a positive finite scale", where);
    }
    codecs.push_back(Codec::from_spec(f));
  }
  const std::uint32_t xyz = field_bit(PointField::kCartesianX) |
                            field_bit(PointField::kCartesianY) | field_bit(PointField::kCartesianZ);
  if ((mask & xyz) != 0 && (mask & xyz) != xyz) {
    throw error("cartesianX, cartesianY and cartesianZ must be declared together", where);
  }
  scan_ = std::make_unique<OpenScan>();
  scan_->header = header;
  scan_->fields = fields;
  scan_->doubles.resize(fields.size());
  scan_->integers.resize(fields.size());
  scan_->cv = std::make_unique<CompressedVectorWriter>(*file_, std::move(codecs));
}

void Writer::add_points(const PointBuffer& points) {
  if (!scan_) throw error("add_points without begin_scan");
  OpenScan& s = *scan_;
  const std::size_t n = points.size;
  std::vector<const double*> dptr(s.fields.size(), nullptr);
  std::vector<const std::int64_t*> iptr(s.fields.size(), nullptr);
  for (std::size_t k = 0; k < s.fields.size(); ++k) {
    const FieldSpec& f = s.fields[k];
    if (!points.present(f.field)) {
      throw error(std::string("points lack declared field '") + field_name(f.field) + "'");
    }
    with_vector(points, f.field, [&](const auto& v) {
      using T = typename std::decay_t<decltype(v)>::value_type;
      if (v.size() < n) throw error(std::string("field '") + field_name(f.field) + "' is short");
      if (f.kind == FieldKind::kInteger) {
        auto& out = s.integers[k];
        out.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
          if constexpr (std::is_floating_point_v<T>) {
            if (!(std::abs(v[i]) < 9.2e18)) {
              throw error(std::string("field '") + field_name(f.field) + "' value is not finite");
            }
            out[i] = std::llround(v[i]);
          } else {
            out[i] = v[i];
          }
        }
        iptr[k] = out.data();
      } else if constexpr (std::is_same_v<T, double>) {
        dptr[k] = v.data();
      } else {
        auto& out = s.doubles[k];
        out.assign(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n));
        dptr[k] = out.data();
      }
    });
  }
  try {
    s.cv->add_records(n, dptr, iptr);
  } catch (const Error& e) {
    throw error(e.message(), "/data3D/" + std::to_string(data3d_.children.size()) + "/points");
  }
  // Bounds over valid points (cartesian/spherical invalid state 0 or absent).
  const bool cart = points.present(PointField::kCartesianX);
  const bool cart_state = points.present(PointField::kCartesianInvalidState);
  const bool sph = points.present(PointField::kSphericalRange);
  const bool sph_state = points.present(PointField::kSphericalInvalidState);
  for (std::size_t i = 0; i < n; ++i) {
    if (cart && (!cart_state || points.cartesian_invalid_state[i] == 0)) {
      s.x.add(points.cartesian_x[i]);
      s.y.add(points.cartesian_y[i]);
      s.z.add(points.cartesian_z[i]);
    }
    if (sph && (!sph_state || points.spherical_invalid_state[i] == 0)) {
      s.range.add(points.spherical_range[i]);
      if (points.present(PointField::kSphericalAzimuth)) s.azimuth.add(points.spherical_azimuth[i]);
      if (points.present(PointField::kSphericalElevation))
        s.elevation.add(points.spherical_elevation[i]);
    }
    if (points.present(PointField::kRowIndex)) s.row.add(points.row_index[i]);
    if (points.present(PointField::kColumnIndex)) s.column.add(points.column_index[i]);
    if (points.present(PointField::kReturnIndex)) s.ret.add(points.return_index[i]);
    if (points.present(PointField::kIntensity)) s.intensity.add(points.intensity[i]);
    if (points.present(PointField::kColorRed)) s.red.add(points.color_red[i]);
    if (points.present(PointField::kColorGreen)) s.green.add(points.color_green[i]);
    if (points.present(PointField::kColorBlue)) s.blue.add(points.color_blue[i]);
  }
}

std::size_t Writer::end_scan() {
  if (!scan_) throw error("end_scan without begin_scan");
  OpenScan& s = *scan_;
  s.cv->finish();
  Data3D h = s.header;
  if (h.guid.empty()) h.guid = make_guid();
  if (!h.cartesian_bounds && !s.x.empty()) {
    h.cartesian_bounds = CartesianBounds{s.x.lo, s.x.hi, s.y.lo, s.y.hi, s.z.lo, s.z.hi};
  }
  if (!h.spherical_bounds && !s.range.empty()) {
    h.spherical_bounds = SphericalBounds{s.range.lo,     s.range.hi,   s.elevation.lo,
                                         s.elevation.hi, s.azimuth.lo, s.azimuth.hi};
    if (s.elevation.empty())
      h.spherical_bounds->elevation_min = h.spherical_bounds->elevation_max = 0;
    if (s.azimuth.empty()) h.spherical_bounds->azimuth_start = h.spherical_bounds->azimuth_end = 0;
  }
  auto as_int = [](const MinMax& m, bool lo) {
    return m.empty() ? std::int64_t{0} : static_cast<std::int64_t>(lo ? m.lo : m.hi);
  };
  if (!h.index_bounds && (!s.row.empty() || !s.column.empty() || !s.ret.empty())) {
    h.index_bounds =
        IndexBounds{as_int(s.row, true),     as_int(s.row, false), as_int(s.column, true),
                    as_int(s.column, false), as_int(s.ret, true),  as_int(s.ret, false)};
  }
  auto limits = [&](PointField f, const MinMax& seen) -> std::pair<double, double> {
    for (const FieldSpec& spec : s.fields) {
      if (spec.field == f && spec.kind != FieldKind::kFloat) {
        return {spec_value(spec, spec.minimum), spec_value(spec, spec.maximum)};
      }
    }
    return seen.empty() ? std::pair{0.0, 0.0} : std::pair{seen.lo, seen.hi};
  };
  std::uint32_t mask = 0;
  for (const FieldSpec& f : s.fields)
    mask |= field_bit(f.field);
  if (!h.intensity_limits && (mask & field_bit(PointField::kIntensity))) {
    const auto [lo, hi] = limits(PointField::kIntensity, s.intensity);
    h.intensity_limits = IntensityLimits{lo, hi};
  }
  if (!h.color_limits && (mask & field_bit(PointField::kColorRed))) {
    const auto r = limits(PointField::kColorRed, s.red);
    const auto g = limits(PointField::kColorGreen, s.green);
    const auto b = limits(PointField::kColorBlue, s.blue);
    h.color_limits = ColorLimits{r.first, r.second, g.first, g.second, b.first, b.second};
  }
  Element e = data3d_to_element(h);
  Element points;
  points.name = "points";
  points.type = ElementType::kCompressedVector;
  points.file_offset = s.cv->section_physical_offset();
  points.record_count = s.cv->record_count();
  Element proto = Element::make_structure("prototype");
  for (const FieldSpec& f : s.fields)
    proto.children.push_back(prototype_element(f));
  points.children.push_back(std::move(proto));
  points.children.push_back(vector_element("codecs"));
  e.children.push_back(std::move(points));
  data3d_.children.push_back(std::move(e));
  scan_.reset();
  return data3d_.children.size() - 1;
}

std::size_t Writer::write_scan(const Data3D& header, const std::vector<FieldSpec>& fields,
                               const PointBuffer& points) {
  begin_scan(header, fields);
  add_points(points);
  return end_scan();
}

BlobRef Writer::write_blob(std::span<const std::uint8_t> bytes) {
  file_->align(4);
  const std::uint64_t start = file_->logical_position();
  const std::uint64_t section = (16 + bytes.size() + 3) / 4 * 4;
  std::uint8_t h[16] = {};
  h[0] = 0;  // blob section
  store_le<std::uint64_t>(h + 8, section);
  file_->write(h);
  file_->write(bytes);
  file_->align(4);
  return BlobRef{logical_to_physical(start), bytes.size()};
}

std::size_t Writer::add_image(const Image2D& image, std::span<const std::uint8_t> encoded,
                              std::span<const std::uint8_t> mask) {
  const std::string where = "/images2D/" + std::to_string(images2d_.children.size());
  if (closed_) throw error("writer is closed", where);
  if (scan_) throw error("add_image while a scan is open", where);
  if (encoded.empty()) throw error("image has no bytes", where);
  if (image.width <= 0 || image.height <= 0)
    throw error("image width and height must be > 0", where);
  Element e = image2d_to_element(image);
  if (e.find("guid")->string_value.empty()) e.children.front().string_value = make_guid();
  const BlobRef blob = write_blob(encoded);
  std::optional<BlobRef> mask_blob;
  if (!mask.empty()) mask_blob = write_blob(mask);
  static constexpr const char* kRepNames[] = {"visualReferenceRepresentation",
                                              "pinholeRepresentation", "sphericalRepresentation",
                                              "cylindricalRepresentation"};
  Element rep = Element::make_structure(kRepNames[static_cast<int>(image.representation)]);
  Element b;
  b.name = image.format == ImageFormat::kJpeg ? "jpegImage" : "pngImage";
  b.type = ElementType::kBlob;
  b.file_offset = blob.file_offset;
  b.length = blob.length;
  rep.children.push_back(b);
  if (mask_blob) {
    b.name = "imageMask";
    b.file_offset = mask_blob->file_offset;
    b.length = mask_blob->length;
    rep.children.push_back(b);
  }
  rep.children.push_back(Element::make_integer("imageWidth", image.width));
  rep.children.push_back(Element::make_integer("imageHeight", image.height));
  if (image.representation != ImageRepresentation::kVisualReference) {
    rep.children.push_back(Element::make_float("pixelWidth", image.pixel_width));
    rep.children.push_back(Element::make_float("pixelHeight", image.pixel_height));
  }
  if (image.representation == ImageRepresentation::kPinhole) {
    rep.children.push_back(Element::make_float("focalLength", image.focal_length));
    rep.children.push_back(Element::make_float("principalPointX", image.principal_point_x));
    rep.children.push_back(Element::make_float("principalPointY", image.principal_point_y));
  }
  if (image.representation == ImageRepresentation::kCylindrical) {
    rep.children.push_back(Element::make_float("radius", image.radius));
    rep.children.push_back(Element::make_float("principalPointY", image.principal_point_y));
  }
  e.children.push_back(std::move(rep));
  images2d_.children.push_back(std::move(e));
  return images2d_.children.size() - 1;
}

std::uint64_t Writer::close() {
  if (closed_) throw error("writer closed twice");
  if (scan_) end_scan();
  Element root = Element::make_structure("e57Root");
  root.namespaces = options_.namespaces;
  root.children.push_back(Element::make_string("formatName", "ASTM E57 3D Imaging Data File"));
  root.children.push_back(
      Element::make_string("guid", options_.guid.empty() ? make_guid() : options_.guid));
  root.children.push_back(Element::make_integer("versionMajor", 1));
  root.children.push_back(Element::make_integer("versionMinor", 0));
  root.children.push_back(Element::make_string("e57LibraryVersion", options_.library_version));
  root.children.push_back(Element::make_string("coordinateMetadata", options_.coordinate_metadata));
  if (options_.creation_time) {
    root.children.push_back(datetime_to_element("creationDateTime", *options_.creation_time));
  }
  root.children.push_back(std::move(data3d_));
  root.children.push_back(std::move(images2d_));
  for (const Element& e : options_.extra_root_children)
    root.children.push_back(e);
  const std::string xml = to_xml(root);
  file_->align(4);
  FileHeader header;
  header.xml_physical_offset = file_->physical_position();
  header.xml_logical_length = xml.size();
  file_->write({reinterpret_cast<const std::uint8_t*>(xml.data()), xml.size()});
  const std::uint64_t length = file_->finish(header);
  closed_ = true;
  return length;
}

}  // namespace coloc::e57
