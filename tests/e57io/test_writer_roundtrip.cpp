// Writer -> Reader round trips: random prototypes and sizes crossing packet and page boundaries,
// several scans, images with poses and masks; plus an independent check of what we write (page
// CRCs recomputed from the raw bytes, header fields, and the XML parsed directly with pugixml).

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <pugixml.hpp>
#include <random>

#include "e57io/crc32c.hpp"
#include "e57io/paged_file.hpp"
#include "e57io/point_access.hpp"
#include "e57io/reader.hpp"
#include "e57io/writer.hpp"
#include "tests/testing/data.hpp"

namespace coloc::e57 {
namespace {

using F = PointField;

// A random prototype (each standard field with a random encoding) and random points for it.
struct Sample {
  std::vector<FieldSpec> specs;
  PointBuffer points;
};

void fill_points(std::mt19937_64& rng, Sample& s, std::size_t n);

Sample random_sample(std::mt19937_64& rng, std::size_t n) {
  auto coin = [&] { return (rng() & 1) != 0; };
  auto pick = [&](int k) { return static_cast<int>(rng() % static_cast<unsigned>(k)); };
  Sample s;
  {  // cartesian coordinates always, so a scan is never without fields
    const int enc = pick(3);
    for (F f : {F::kCartesianX, F::kCartesianY, F::kCartesianZ}) {
      s.specs.push_back(enc == 0   ? FieldSpec::scaled(f, 1e-3, -100, 100)
                        : enc == 1 ? FieldSpec::float64(f)
                                   : FieldSpec::float32(f));
    }
    if (coin()) s.specs.push_back(FieldSpec::integer(F::kCartesianInvalidState, 0, 2));
  }
  if (coin()) {
    s.specs.push_back(FieldSpec::float64(F::kSphericalRange));
    s.specs.push_back(FieldSpec::scaled(F::kSphericalAzimuth, 1e-6, -3.2, 3.2));
    s.specs.push_back(FieldSpec::float32(F::kSphericalElevation));
  }
  if (coin()) {
    const int enc = pick(3);
    s.specs.push_back(enc == 0   ? FieldSpec::scaled(F::kIntensity, 1.0 / 4096, 0, 1)
                      : enc == 1 ? FieldSpec::float32(F::kIntensity)
                                 : FieldSpec::integer(F::kIntensity, 0, 4095));
    if (coin()) s.specs.push_back(FieldSpec::integer(F::kIsIntensityInvalid, 0, 1));
  }
  if (coin()) {
    const std::int64_t max = coin() ? 255 : 65535;
    for (F f : {F::kColorRed, F::kColorGreen, F::kColorBlue}) {
      s.specs.push_back(FieldSpec::integer(f, 0, max));
    }
  }
  if (coin()) {
    s.specs.push_back(FieldSpec::integer(F::kRowIndex, 0, 1 + pick(100000)));
    s.specs.push_back(FieldSpec::integer(F::kColumnIndex, -7, 7));  // 4 bits, negative minimum
  }
  if (coin()) {
    s.specs.push_back(FieldSpec::integer(F::kReturnIndex, 0, 0));  // constant: 0 bits
    s.specs.push_back(FieldSpec::integer(F::kReturnCount, 1, 1));
  }
  if (coin()) {
    s.specs.push_back(coin() ? FieldSpec::float64(F::kTimeStamp)
                             : FieldSpec::scaled(F::kTimeStamp, 1e-6, 0, 5000));
    s.specs.push_back(FieldSpec::integer(F::kIsTimeStampInvalid, 0, 1));
  }
  fill_points(rng, s, n);
  return s;
}

// Random values within each field's range (integral for Integer, on the grid for Scaled).
void fill_points(std::mt19937_64& rng, Sample& s, std::size_t n) {
  std::uint32_t mask = 0;
  for (const auto& spec : s.specs)
    mask |= field_bit(spec.field);
  s.points.reset(mask, n);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    for (const FieldSpec& spec : s.specs) {
      const bool flt = spec.kind == FieldKind::kFloat;
      const double lo = flt ? -50.0 : static_cast<double>(spec.minimum);
      const double hi = flt ? 50.0 : static_cast<double>(spec.maximum);
      double v = spec.kind == FieldKind::kInteger ? std::round(lo + u(rng) * (hi - lo))
                                                  : lo + u(rng) * (hi - lo);
      if (spec.kind == FieldKind::kScaledInteger) v = v * spec.scale + spec.offset;
      with_vector(s.points, spec.field, [&](auto& vec) {
        vec[i] = static_cast<typename std::decay_t<decltype(vec)>::value_type>(v);
      });
    }
  }
}

// The value the reader must return for a written double `v` under `spec`.
double stored(const FieldSpec& spec, double v) {
  switch (spec.kind) {
    case FieldKind::kScaledInteger:
      return std::round((v - spec.offset) / spec.scale) * spec.scale + spec.offset;
    case FieldKind::kFloat:
      return spec.single_precision ? static_cast<double>(static_cast<float>(v)) : v;
    case FieldKind::kInteger:
      return std::round(v);
  }
  return v;
}

void expect_same(const Sample& s, const PointBuffer& got) {
  ASSERT_EQ(got.size, s.points.size);
  ASSERT_EQ(got.present_mask, s.points.present_mask);
  const PointBuffer& w = s.points;
  for (const FieldSpec& spec : s.specs) {
    for (std::size_t i = 0; i < w.size; ++i) {
      switch (spec.field) {
        case F::kCartesianX:
          ASSERT_EQ(got.cartesian_x[i], stored(spec, w.cartesian_x[i])) << i;
          break;
        case F::kCartesianZ:
          ASSERT_EQ(got.cartesian_z[i], stored(spec, w.cartesian_z[i])) << i;
          break;
        case F::kSphericalAzimuth:
          ASSERT_EQ(got.spherical_azimuth[i], stored(spec, w.spherical_azimuth[i]));
          break;
        case F::kSphericalElevation:
          ASSERT_EQ(got.spherical_elevation[i], stored(spec, w.spherical_elevation[i]));
          break;
        case F::kIntensity:
          ASSERT_EQ(got.intensity[i], static_cast<float>(stored(spec, w.intensity[i]))) << i;
          break;
        case F::kColorBlue:
          ASSERT_EQ(got.color_blue[i], w.color_blue[i]);
          break;
        case F::kCartesianInvalidState:
          ASSERT_EQ(got.cartesian_invalid_state[i], w.cartesian_invalid_state[i]);
          break;
        case F::kRowIndex:
          ASSERT_EQ(got.row_index[i], w.row_index[i]);
          break;
        case F::kColumnIndex:
          ASSERT_EQ(got.column_index[i], w.column_index[i]);
          break;
        case F::kReturnCount:
          ASSERT_EQ(got.return_count[i], 1);
          break;
        case F::kTimeStamp:
          ASSERT_EQ(got.time_stamp[i], stored(spec, w.time_stamp[i]));
          break;
        case F::kIsTimeStampInvalid:
          ASSERT_EQ(got.is_time_stamp_invalid[i], w.is_time_stamp_invalid[i]);
          break;
        default:
          break;
      }
    }
  }
}

TEST(E57Writer, RandomPrototypesAndSizesRoundTrip) {
  const auto dir = testing::temp_dir("e57_roundtrip");
  std::mt19937_64 rng(42);
  // 0 and 1 point; a packet holds ~5-60 k records; 150 k crosses many packets and pages.
  const std::size_t sizes[] = {0, 1, 7, 1000, 20011, 150001};
  int file_no = 0;
  for (std::size_t n : sizes) {
    for (int rep = 0; rep < 3; ++rep) {
      const Sample s = random_sample(rng, n);
      // Appended, not "r" + std::to_string(...): GCC 12 warns falsely about that in a unity
      // build (-Wrestrict, its bug 105329).
      std::string name = "r";
      name += std::to_string(file_no++);
      name += ".e57";
      const auto path = dir / name;
      {
        Writer w(path);
        Data3D h;
        h.name = "scan " + std::to_string(n);
        w.begin_scan(h, s.specs);
        // Add in uneven pieces so packets and add_points calls do not line up.
        PointBuffer piece;
        std::size_t at = 0;
        while (at < n) {
          const std::size_t k = std::min<std::size_t>(n - at, 1 + rng() % 30000);
          piece.reset(s.points.present_mask, 0);
          for (std::size_t i = 0; i < k; ++i)
            piece.append(s.points, at + i);
          w.add_points(piece);
          at += k;
        }
        w.end_scan();
        w.close();
      }
      Reader r(path);
      ASSERT_EQ(r.scans().size(), 1u);
      EXPECT_EQ(r.scans()[0].point_count, n);
      EXPECT_EQ(r.scans()[0].name, "scan " + std::to_string(n));
      expect_same(s, r.read_points(0));
      EXPECT_NO_THROW(r.verify());
    }
  }
}

std::vector<std::uint8_t> fake_image(std::size_t n, std::uint8_t seed) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i)
    v[i] = static_cast<std::uint8_t>(seed + i * 7);
  v[0] = 0xFF;
  v[1] = 0xD8;
  return v;
}

// Two stations, each with colour + intensity points and six pinhole cube faces: the shape of
// the synthetic twin.
std::filesystem::path write_stations(const std::filesystem::path& dir) {
  const auto path = dir / "stations.e57";
  Writer w(path, {.guid = "{file-guid}", .coordinate_metadata = "local"});
  for (int st = 0; st < 2; ++st) {
    Data3D h;
    h.guid = "{scan-" + std::to_string(st) + "}";
    h.name = "station " + std::to_string(st);
    h.sensor_vendor = "coloc";
    h.pose = Pose{{std::sqrt(0.5), 0, 0, std::sqrt(0.5)}, {10.0 * st, 2, 1.5}};
    h.acquisition_start = DateTime{1.4e9 + st, false};
    PointBuffer p;
    p.reset(field_bit(F::kCartesianX) | field_bit(F::kCartesianY) | field_bit(F::kCartesianZ) |
                field_bit(F::kIntensity) | field_bit(F::kColorRed) | field_bit(F::kColorGreen) |
                field_bit(F::kColorBlue) | field_bit(F::kRowIndex) | field_bit(F::kColumnIndex),
            3000);
    for (std::size_t i = 0; i < p.size; ++i) {
      p.cartesian_x[i] = -5.0 + 0.001 * static_cast<double>(i);
      p.cartesian_y[i] = 0.5 * st;
      p.cartesian_z[i] = 2.0 - 0.0005 * static_cast<double>(i);
      p.intensity[i] = static_cast<float>(i % 100) / 100.0f;
      p.color_red[i] = static_cast<float>(i % 256);
      p.color_green[i] = 100;
      p.color_blue[i] = static_cast<float>(255 - i % 256);
      p.row_index[i] = static_cast<std::int32_t>(i / 60);
      p.column_index[i] = static_cast<std::int32_t>(i % 60);
    }
    w.write_scan(
        h,
        {FieldSpec::scaled(F::kCartesianX, 1e-4, -50, 50),
         FieldSpec::scaled(F::kCartesianY, 1e-4, -50, 50),
         FieldSpec::scaled(F::kCartesianZ, 1e-4, -50, 50), FieldSpec::float32(F::kIntensity),
         FieldSpec::integer(F::kColorRed, 0, 255), FieldSpec::integer(F::kColorGreen, 0, 255),
         FieldSpec::integer(F::kColorBlue, 0, 255), FieldSpec::integer(F::kRowIndex, 0, 49),
         FieldSpec::integer(F::kColumnIndex, 0, 59)},
        p);
    for (int face = 0; face < 6; ++face) {
      Image2D im;
      im.name = "station " + std::to_string(st) + " face " + std::to_string(face);
      im.associated_data3d_guid = h.guid;
      im.representation = ImageRepresentation::kPinhole;
      im.format = face % 2 == 0 ? ImageFormat::kJpeg : ImageFormat::kPng;
      im.width = im.height = 2048;
      im.pixel_width = im.pixel_height = 1e-5;
      im.focal_length = 1024 * 1e-5;
      im.principal_point_x = im.principal_point_y = 1023.5;
      im.pose = Pose{{1, 0, 0, 0}, {10.0 * st, 2, 1.5 + 0.01 * face}};
      const auto bytes =
          fake_image(1500 + 311 * static_cast<std::size_t>(face), static_cast<std::uint8_t>(face));
      if (face == 5) {
        w.add_image(im, bytes, fake_image(99, 9));
      } else {
        w.add_image(im, bytes);
      }
    }
  }
  Image2D pano;
  pano.name = "panorama";
  pano.representation = ImageRepresentation::kSpherical;
  pano.width = 4000;
  pano.height = 2000;
  pano.pixel_width = pano.pixel_height = M_PI / 2000;
  w.add_image(pano, fake_image(5000, 3));
  w.close();
  return path;
}

TEST(E57Writer, StationsWithImagesAndPosesRoundTrip) {
  const auto path = write_stations(testing::temp_dir("e57_stations"));
  Reader r(path);
  EXPECT_EQ(r.info().guid, "{file-guid}");
  EXPECT_EQ(r.info().coordinate_metadata, "local");
  ASSERT_EQ(r.scans().size(), 2u);
  ASSERT_EQ(r.images().size(), 13u);
  const Data3D& s1 = r.scans()[1];
  EXPECT_EQ(s1.name, "station 1");
  EXPECT_EQ(s1.guid, "{scan-1}");
  EXPECT_EQ(s1.sensor_vendor, "coloc");
  ASSERT_TRUE(s1.pose && s1.cartesian_bounds && s1.color_limits && s1.index_bounds &&
              s1.intensity_limits && s1.acquisition_start);
  EXPECT_EQ(s1.pose->rotation.z, std::sqrt(0.5));
  EXPECT_EQ(s1.pose->translation.x, 10.0);
  EXPECT_EQ(s1.acquisition_start->gps_seconds, 1.4e9 + 1);
  EXPECT_NEAR(s1.cartesian_bounds->x_min, -5.0, 1e-12);
  EXPECT_NEAR(s1.cartesian_bounds->x_max, -5.0 + 2.999, 1e-12);
  EXPECT_EQ(s1.color_limits->red_max, 255);
  EXPECT_EQ(s1.index_bounds->row_max, 49);
  EXPECT_EQ(s1.index_bounds->column_max, 59);
  const PointBuffer p = r.read_points(1);
  ASSERT_EQ(p.size, 3000u);
  EXPECT_NEAR(p.cartesian_x[1234], -5.0 + 1.234, 1e-9);
  EXPECT_EQ(p.cartesian_y[5], 0.5);
  EXPECT_EQ(p.color_red[300], 300 % 256);
  EXPECT_EQ(p.intensity[42], 0.42f);
  EXPECT_EQ(p.row_index[2999], 49);

  for (int st = 0; st < 2; ++st) {
    for (int face = 0; face < 6; ++face) {
      const std::size_t i = static_cast<std::size_t>(st * 6 + face);
      const Image2D& im = r.images()[i];
      EXPECT_EQ(im.name, "station " + std::to_string(st) + " face " + std::to_string(face));
      EXPECT_EQ(im.representation, ImageRepresentation::kPinhole);
      EXPECT_EQ(im.format, face % 2 == 0 ? ImageFormat::kJpeg : ImageFormat::kPng);
      EXPECT_EQ(im.associated_data3d_guid, r.scans()[static_cast<std::size_t>(st)].guid);
      EXPECT_EQ(im.width, 2048);
      EXPECT_EQ(im.focal_length, 1024 * 1e-5);
      EXPECT_EQ(im.principal_point_x, 1023.5);
      ASSERT_TRUE(im.pose.has_value());
      EXPECT_EQ(im.pose->translation.z, 1.5 + 0.01 * face);
      EXPECT_EQ(r.read_image(i), fake_image(1500 + 311 * static_cast<std::size_t>(face),
                                            static_cast<std::uint8_t>(face)));
      EXPECT_EQ(r.read_image_mask(i).size(), face == 5 ? 99u : 0u);
    }
  }
  EXPECT_EQ(r.images()[12].representation, ImageRepresentation::kSpherical);
  EXPECT_EQ(r.images()[12].pixel_width, M_PI / 2000);
  EXPECT_FALSE(r.images()[12].pose.has_value());
  EXPECT_EQ(r.read_image(12), fake_image(5000, 3));
}

TEST(E57Writer, WrittenFileHasValidPagesHeaderAndXml) {
  const auto path = write_stations(testing::temp_dir("e57_raw"));
  std::ifstream f(path, std::ios::binary);
  const std::vector<std::uint8_t> raw{std::istreambuf_iterator<char>(f), {}};
  ASSERT_EQ(raw.size() % 1024, 0u);
  // Every page: CRC-32C of its 1020 data bytes, stored big-endian (recomputed here).
  for (std::size_t page = 0; page < raw.size() / 1024; ++page) {
    const std::uint8_t* p = raw.data() + page * 1024;
    const std::uint32_t want = (std::uint32_t{p[1020]} << 24) | (std::uint32_t{p[1021]} << 16) |
                               (std::uint32_t{p[1022]} << 8) | p[1023];
    ASSERT_EQ(crc32c_portable(p, 1020), want) << "page " << page;
  }
  // Header.
  ASSERT_EQ(std::string(raw.begin(), raw.begin() + 8), "ASTM-E57");
  FileHeader h = decode_header(raw.data(), path.string());
  EXPECT_EQ(h.version_major, 1u);
  EXPECT_EQ(h.version_minor, 0u);
  EXPECT_EQ(h.physical_length, raw.size());
  EXPECT_EQ(h.page_size, 1024u);
  // XML, gathered by skipping CRCs, parsed directly with pugixml.
  std::string xml;
  std::uint64_t phys = h.xml_physical_offset;
  while (xml.size() < h.xml_logical_length) {
    if (phys % 1024 == 1020) phys += 4;
    xml.push_back(static_cast<char>(raw[phys++]));
  }
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_string(xml.c_str()));
  const pugi::xml_node root = doc.child("e57Root");
  ASSERT_TRUE(root);
  EXPECT_STREQ(root.attribute("type").value(), "Structure");
  EXPECT_STREQ(root.attribute("xmlns").value(), "http://www.astm.org/COMMIT/E57/2010-e57-v1.0");
  EXPECT_STREQ(root.child("formatName").text().get(), "ASTM E57 3D Imaging Data File");
  EXPECT_STREQ(root.child("versionMajor").text().get(), "1");
  const pugi::xml_node points = root.child("data3D").first_child().child("points");
  EXPECT_STREQ(points.attribute("type").value(), "CompressedVector");
  EXPECT_STREQ(points.attribute("recordCount").value(), "3000");
  const pugi::xml_node cx = points.child("prototype").child("cartesianX");
  EXPECT_STREQ(cx.attribute("type").value(), "ScaledInteger");
  EXPECT_STREQ(cx.attribute("minimum").value(), "-500000");
  EXPECT_STREQ(cx.attribute("maximum").value(), "500000");
  EXPECT_STREQ(points.child("codecs").attribute("type").value(), "Vector");
  // Prototype values lie within their own bounds (libE57Format checks): rowIndex [0, 49] -> 0.
  EXPECT_STREQ(points.child("prototype").child("cartesianX").text().get(), "0");
  // The compressed vector section header the XML points at.
  const std::uint64_t cv = points.attribute("fileOffset").as_ullong();
  EXPECT_EQ(raw[cv], 1);
  const pugi::xml_node pin = root.child("images2D").first_child().child("pinholeRepresentation");
  ASSERT_TRUE(pin);
  EXPECT_STREQ(pin.child("imageWidth").attribute("type").value(), "Integer");
  const std::uint64_t blob = pin.child("jpegImage").attribute("fileOffset").as_ullong();
  EXPECT_EQ(raw[blob], 0);  // blob section id
  EXPECT_EQ(raw[blob + 16], 0xFF);
}

TEST(E57Writer, RejectsBadInputWithClearErrors) {
  const auto dir = testing::temp_dir("e57_writer_bad");
  Writer w(dir / "bad.e57");
  PointBuffer p;
  p.reset(field_bit(F::kColorRed), 2);
  p.color_red = {10, 300};
  w.begin_scan({}, {FieldSpec::integer(F::kColorRed, 0, 255)});
  try {
    w.add_points(p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("300"), std::string::npos);
    EXPECT_EQ(e.context().element, "/data3D/0/points");
  }
  PointBuffer q;
  q.reset(field_bit(F::kIntensity), 1);
  EXPECT_THROW(w.add_points(q), Error);  // colorRed missing
  EXPECT_THROW(w.add_image(Image2D{.width = 1, .height = 1}, fake_image(10, 0)),
               Error);  // scan open
  EXPECT_THROW(w.begin_scan({}, {}), Error);
  w.end_scan();
  EXPECT_THROW(w.begin_scan({}, {FieldSpec::float64(F::kCartesianX)}), Error);  // no Y/Z
  EXPECT_THROW(w.begin_scan({}, {FieldSpec::integer(F::kRowIndex, 5, 1)}), Error);
  EXPECT_THROW(w.begin_scan({}, {}), Error);  // no fields
}

TEST(E57Writer, UnclosedWriterLeavesNoFile) {
  const auto dir = testing::temp_dir("e57_writer_unclosed");
  { Writer w(dir / "x.e57"); }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.e57"));
}

}  // namespace
}  // namespace coloc::e57

namespace coloc::e57 {
namespace {

TEST(E57Writer, PrototypeValuesStayWithinTheirBounds) {
  const auto path = testing::temp_dir("e57_proto") / "p.e57";
  Writer w(path);
  PointBuffer p;
  p.reset(field_bit(PointField::kReturnCount) | field_bit(PointField::kColumnIndex), 3);
  p.return_count = {1, 1, 1};
  p.column_index = {-3, -4, -5};
  w.write_scan({},
               {FieldSpec::integer(PointField::kReturnCount, 1, 1),
                FieldSpec::integer(PointField::kColumnIndex, -9, -2)},
               p);
  w.close();
  Reader r(path);
  const Element* proto = r.root().find("data3D")->children[0].find_path("points/prototype");
  EXPECT_EQ(proto->find("returnCount")->int_value, 1);
  EXPECT_EQ(proto->find("columnIndex")->int_value, -2);
  const PointBuffer b = r.read_points(0);
  EXPECT_EQ(b.column_index, (std::vector<std::int32_t>{-3, -4, -5}));
  EXPECT_EQ(b.return_count, (std::vector<std::int32_t>{1, 1, 1}));
}

}  // namespace
}  // namespace coloc::e57
