// Reading the real corpus under ../shared/data/e57 (files written by libE57Format, the Rust e57
// crate, InteliSum/pye57 and las2e57). Expected values were established from the files: header
// counts and bounds in their XML, and sums / first points decoded by our reader and checked
// against the XML bounds and against each other across encodings.

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <limits>

#include "e57io/reader.hpp"
#include "tests/testing/data.hpp"

namespace coloc::e57 {
namespace {

struct Stats {
  std::size_t valid = 0;
  double sx = 0, sy = 0, sz = 0;
  double min_x = std::numeric_limits<double>::infinity(), max_x = -min_x;
};

Stats stats_of(const PointBuffer& b) {
  Stats s;
  for (std::size_t i = 0; i < b.size; ++i) {
    if (b.present(PointField::kCartesianInvalidState) && b.cartesian_invalid_state[i] != 0)
      continue;
    ++s.valid;
    s.sx += b.cartesian_x[i];
    s.sy += b.cartesian_y[i];
    s.sz += b.cartesian_z[i];
    s.min_x = std::min(s.min_x, b.cartesian_x[i]);
    s.max_x = std::max(s.max_x, b.cartesian_x[i]);
  }
  return s;
}

std::vector<std::uint8_t> file_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

constexpr std::uint32_t kXyz = field_bit(PointField::kCartesianX) |
                               field_bit(PointField::kCartesianY) |
                               field_bit(PointField::kCartesianZ);

TEST(E57Corpus, BunnyAgreesAcrossThreeEncodings) {
  COLOC_REQUIRE_DATA(dbl, "e57/libE57Format-test-data/reference/bunnyDouble.e57");
  COLOC_REQUIRE_DATA(i32, "e57/libE57Format-test-data/reference/bunnyInt32.e57");
  COLOC_REQUIRE_DATA(flt, "e57/cry-inc-e57/bunnyFloat.e57");
  Reader rd(dbl), ri(i32), rf(flt);
  ASSERT_EQ(ri.scans().size(), 1u);
  EXPECT_EQ(ri.scans()[0].name, "bunny");
  EXPECT_EQ(ri.scans()[0].prototype[0].spec.kind, FieldKind::kScaledInteger);
  EXPECT_EQ(rd.scans()[0].prototype[0].spec.kind, FieldKind::kFloat);
  EXPECT_TRUE(rf.scans()[0].prototype[0].spec.single_precision);
  const PointBuffer d = rd.read_points(0), i = ri.read_points(0), f = rf.read_points(0);
  ASSERT_EQ(d.size, 30571u);
  ASSERT_EQ(i.size, 30571u);
  ASSERT_EQ(f.size, 30571u);
  for (std::size_t k = 0; k < d.size; ++k) {
    ASSERT_NEAR(d.cartesian_x[k], i.cartesian_x[k], 1e-9) << k;
    ASSERT_NEAR(d.cartesian_y[k], i.cartesian_y[k], 1e-9) << k;
    ASSERT_NEAR(d.cartesian_z[k], f.cartesian_z[k], 1e-7) << k;  // single precision
  }
  const Stats s = stats_of(d);
  EXPECT_EQ(s.valid, 30571u);
  EXPECT_NEAR(s.sx, -841.093298, 1e-5);
  EXPECT_NEAR(s.sy, 3151.19874, 1e-4);
  EXPECT_NEAR(s.sz, 264.243972, 1e-5);
  EXPECT_DOUBLE_EQ(s.min_x, -0.094689);
  EXPECT_DOUBLE_EQ(s.max_x, 0.061009);
  EXPECT_DOUBLE_EQ(d.cartesian_x[0], -0.07063);
  EXPECT_DOUBLE_EQ(d.cartesian_y[0], 0.04015);
  EXPECT_DOUBLE_EQ(d.cartesian_z[30570], 0.004474);
}

TEST(E57Corpus, PumpScanWithColourIntensityGridAndImage) {
  COLOC_REQUIRE_DATA(path, "e57/pye57/pumpAVisualReferenceImage.e57");
  Reader r(path);
  EXPECT_EQ(r.info().guid, "{4F947749-517F-49D1-9AD9-A899110EFFDD}");
  ASSERT_TRUE(r.info().creation_time.has_value());
  EXPECT_NEAR(r.info().creation_time->gps_seconds, 996438465.77999532, 1e-3);
  ASSERT_EQ(r.scans().size(), 1u);
  const Data3D& scan = r.scans()[0];
  EXPECT_EQ(scan.name, "pumpA");
  EXPECT_EQ(scan.point_count, 155201u);
  ASSERT_TRUE(scan.index_bounds && scan.cartesian_bounds && scan.color_limits);
  EXPECT_EQ(scan.index_bounds->row_max, 1073);
  EXPECT_EQ(scan.index_bounds->column_max, 344);
  EXPECT_DOUBLE_EQ(scan.color_limits->red_max, 255);
  EXPECT_NEAR(scan.intensity_limits->maximum, 1.0, 1e-9);  // 32767 * 3.0518509475997192e-5
  const std::uint32_t want = kXyz | field_bit(PointField::kIntensity) |
                             field_bit(PointField::kColorRed) | field_bit(PointField::kRowIndex) |
                             field_bit(PointField::kColumnIndex) |
                             field_bit(PointField::kCartesianInvalidState);
  EXPECT_EQ(scan.field_mask & want, want);
  const PointBuffer b = r.read_points(0);
  const Stats s = stats_of(b);
  EXPECT_EQ(s.valid, 155201u);
  EXPECT_NEAR(s.sx, -74913.31, 0.01);
  EXPECT_NEAR(s.sy, -409112.127, 0.01);
  EXPECT_NEAR(s.sz, -147000.511, 0.01);
  const CartesianBounds& cb = *scan.cartesian_bounds;
  for (std::size_t k = 0; k < b.size; ++k) {
    ASSERT_GE(b.cartesian_x[k], cb.x_min - 1e-6);
    ASSERT_LE(b.cartesian_x[k], cb.x_max + 1e-6);
    ASSERT_GE(b.cartesian_y[k], cb.y_min - 1e-6);
    ASSERT_LE(b.cartesian_z[k], cb.z_max + 1e-6);
    ASSERT_LE(b.row_index[k], 1073);
    ASSERT_LE(b.column_index[k], 344);
  }
  EXPECT_NEAR(b.cartesian_x[0], 1.702286, 1e-9);
  EXPECT_NEAR(b.cartesian_y[0], -3.193588, 1e-9);
  EXPECT_NEAR(b.cartesian_z[0], -1.841843, 1e-9);
  EXPECT_NEAR(b.intensity[0], 0.456556916, 1e-6);
  EXPECT_EQ(b.color_red[0], 51);
  EXPECT_EQ(b.color_green[0], 65);
  EXPECT_EQ(b.color_blue[0], 49);
  EXPECT_EQ(b.row_index[0], 267);
  EXPECT_EQ(b.column_index[0], 0);

  // The column grouping covers every point exactly once, in order.
  const auto groups = r.read_line_groups(0);
  ASSERT_EQ(groups.size(), 345u);
  std::int64_t next = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    EXPECT_EQ(groups[g].id, static_cast<std::int64_t>(g));
    EXPECT_EQ(groups[g].start_point, next);
    next += groups[g].point_count;
  }
  EXPECT_EQ(next, 155201);

  ASSERT_EQ(r.images().size(), 1u);
  const Image2D& im = r.images()[0];
  EXPECT_EQ(im.name, "pumpVisual");
  EXPECT_EQ(im.representation, ImageRepresentation::kVisualReference);
  EXPECT_EQ(im.format, ImageFormat::kJpeg);
  EXPECT_EQ(im.width, 3072);
  EXPECT_EQ(im.height, 2304);
  const auto jpeg = r.read_image(0);
  ASSERT_EQ(jpeg.size(), 1504576u);
  EXPECT_EQ(jpeg[0], 0xFF);
  EXPECT_EQ(jpeg[1], 0xD8);
  EXPECT_NO_THROW(r.verify());
}

TEST(E57Corpus, StreamingMatchesWholeReadAndSelectsFields) {
  COLOC_REQUIRE_DATA(path, "e57/pye57/pumpAVisualReferenceImage.e57");
  Reader r(path);
  const PointBuffer all = r.read_points(0);
  PointStream stream = r.open_points(0, kXyz | field_bit(PointField::kColorGreen));
  PointBuffer chunk;
  std::size_t at = 0;
  while (const std::size_t n = stream.read(chunk, 1000 + at % 777)) {  // odd chunk sizes
    ASSERT_EQ(chunk.size, n);
    EXPECT_FALSE(chunk.present(PointField::kIntensity));
    EXPECT_TRUE(chunk.intensity.empty());
    for (std::size_t k = 0; k < n; ++k) {
      ASSERT_EQ(chunk.cartesian_x[k], all.cartesian_x[at + k]);
      ASSERT_EQ(chunk.color_green[k], all.color_green[at + k]);
    }
    at += n;
  }
  EXPECT_EQ(at, 155201u);
  EXPECT_EQ(stream.points_read(), 155201u);
  EXPECT_THROW(r.open_points(0, field_bit(PointField::kTimeStamp)), Error);
  EXPECT_THROW(r.open_points(1), Error);
}

TEST(E57Corpus, RustCrateImagesAndPoses) {
  COLOC_REQUIRE_DATA(path, "e57/cry-inc-e57/tiny_pc_and_images.e57");
  COLOC_REQUIRE_DATA(castle, "e57/cry-inc-e57/castle.jpg");
  COLOC_REQUIRE_DATA(square, "e57/cry-inc-e57/square.png");
  Reader r(path);
  ASSERT_EQ(r.scans().size(), 1u);
  const PointBuffer b = r.read_points(0);
  ASSERT_EQ(b.size, 2u);
  EXPECT_EQ(b.cartesian_x[1], 1.0f);
  ASSERT_EQ(r.images().size(), 4u);
  const auto& im = r.images();
  EXPECT_EQ(im[0].representation, ImageRepresentation::kVisualReference);
  EXPECT_EQ(im[1].representation, ImageRepresentation::kSpherical);
  EXPECT_EQ(im[2].representation, ImageRepresentation::kPinhole);
  EXPECT_EQ(im[3].representation, ImageRepresentation::kCylindrical);
  EXPECT_EQ(r.read_image(0), file_bytes(castle));
  EXPECT_EQ(r.read_image(1), file_bytes(square));
  EXPECT_EQ(im[1].format, ImageFormat::kPng);
  EXPECT_EQ(im[1].associated_data3d_guid, r.scans()[0].guid);
  ASSERT_TRUE(im[1].pose.has_value());
  EXPECT_EQ(im[1].pose->rotation.w, 0.5);  // stored unnormalized; returned as stored
  EXPECT_EQ(im[1].pose->rotation.x, 1.0);
  EXPECT_EQ(im[1].pose->translation.z, 3.0);
  EXPECT_DOUBLE_EQ(im[1].pixel_width, 0.0314);
  EXPECT_EQ(im[2].focal_length, 123.0);
  EXPECT_EQ(im[2].principal_point_x, 23.0);
  EXPECT_EQ(im[2].principal_point_y, 42.0);
  EXPECT_DOUBLE_EQ(im[2].pixel_width, 0.044);
  EXPECT_DOUBLE_EQ(im[2].pixel_height, 0.033);
  EXPECT_EQ(im[3].radius, 666.0);
  for (const auto& i : im)
    EXPECT_EQ(i.width, 100);
}

TEST(E57Corpus, SphericalOnlyScan) {
  COLOC_REQUIRE_DATA(path, "e57/cry-inc-e57/tiny_spherical.e57");
  Reader r(path);
  const std::uint32_t sph =
      field_bit(PointField::kSphericalRange) | field_bit(PointField::kSphericalAzimuth) |
      field_bit(PointField::kSphericalElevation) | field_bit(PointField::kSphericalInvalidState);
  EXPECT_EQ(r.scans()[0].field_mask, sph);
  const PointBuffer b = r.read_points(0);
  ASSERT_EQ(b.size, 360u);
  EXPECT_FALSE(b.present(PointField::kCartesianX));
  for (std::size_t k = 0; k < b.size; ++k) {
    ASSERT_GE(b.spherical_invalid_state[k], 0);
    ASSERT_LE(b.spherical_invalid_state[k], 2);
  }
}

TEST(E57Corpus, ColouredCubesAndSixteenBitColour) {
  COLOC_REQUIRE_DATA(dbl, "e57/libE57Format-test-data/self/ColouredCubeDouble.e57");
  COLOC_REQUIRE_DATA(flt, "e57/libE57Format-test-data/self/ColouredCubeFloat.e57");
  COLOC_REQUIRE_DATA(las, "e57/libE57Format-test-data/3rdParty/las2e57/ColourRepresentation.e57");
  const PointBuffer d = Reader(dbl).read_points(0);
  const PointBuffer f = Reader(flt).read_points(0);
  ASSERT_EQ(d.size, 7680u);
  ASSERT_EQ(f.size, 7680u);
  for (std::size_t k = 0; k < d.size; ++k) {
    ASSERT_NEAR(d.cartesian_x[k], f.cartesian_x[k], 1e-6);
    ASSERT_EQ(d.color_red[k], f.color_red[k]);
  }
  EXPECT_EQ(d.color_blue[0], 255);
  EXPECT_NEAR(stats_of(d).sx, -49.7208477, 1e-6);

  Reader lr(las);
  EXPECT_EQ(lr.scans()[0].prototype[5].name, "las:pointSourceId");  // extension kept...
  EXPECT_FALSE(lr.scans()[0].prototype[5].field.has_value());       // ...and skipped
  const PointBuffer l = lr.read_points(0);
  ASSERT_EQ(l.size, 153u);
  EXPECT_EQ(l.color_blue[0], 65280);  // 16-bit colour
  EXPECT_DOUBLE_EQ(l.cartesian_x[0], -0.5);
  EXPECT_TRUE(l.present(PointField::kReturnIndex));
  EXPECT_TRUE(lr.read_line_groups(0).empty());  // its groupings are extensions, not by line
  const Element* g = lr.root().find("data3D")->children[0].find_path(
      "pointGroupingSchemes/las:groupingByReturnIndex/groups");
  ASSERT_NE(g, nullptr);
  EXPECT_EQ(g->record_count, 2u);
  EXPECT_NO_THROW(lr.verify());
}

TEST(E57Corpus, ExtensionsAreKept) {
  COLOC_REQUIRE_DATA(path,
                     "e57/libE57Format-test-data/self/PinholeImageWithDistortionParameters.e57");
  COLOC_REQUIRE_DATA(normals, "e57/pye57/testWithNormals.e57");
  Reader r(path);
  ASSERT_EQ(r.images().size(), 3u);
  EXPECT_EQ(r.images()[0].representation, ImageRepresentation::kPinhole);
  EXPECT_EQ(r.read_image(0).size(), 375u);
  ASSERT_EQ(r.root().namespaces.size(), 1u);
  EXPECT_EQ(r.root().namespaces[0].first, "dist");
  const Element* k1 =
      r.root().find("images2D")->children[0].find_path("dist:distortion/dist:CV_K1");
  ASSERT_NE(k1, nullptr);
  EXPECT_NEAR(k1->number(), 1.01, 1e-6);

  Reader n(normals);
  const PointBuffer b = n.read_points(0);
  ASSERT_EQ(b.size, 2u);
  EXPECT_EQ(b.cartesian_x[1], 2.0);
}

TEST(E57Corpus, PoseWithoutRotationIsIdentityRotation) {
  COLOC_REQUIRE_DATA(path, "e57/pye57/translationWithoutRotation.e57");
  Reader r(path);
  ASSERT_TRUE(r.scans()[0].pose.has_value());
  EXPECT_EQ(r.scans()[0].pose->rotation.w, 1.0);
  EXPECT_EQ(r.scans()[0].pose->translation.x, 4.0);
  EXPECT_EQ(r.scans()[0].pose->translation.z, 6.0);
  EXPECT_EQ(r.read_points(0).size, 4u);
}

TEST(E57Corpus, BrokenFilesGiveSpecificErrors) {
  COLOC_REQUIRE_DATA(bad_crc, "e57/libE57Format-test-data/self/bad-crc.e57");
  COLOC_REQUIRE_DATA(invalid_cv, "e57/libE57Format-test-data/self/InvalidCVHeader.e57");
  COLOC_REQUIRE_DATA(zero_invalid, "e57/libE57Format-test-data/self/ZeroPointsInvalid.e57");
  try {
    Reader r(bad_crc);
    FAIL() << "bad-crc.e57 opened";
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("checksum"), std::string::npos);
    ASSERT_TRUE(e.context().page.has_value());
    EXPECT_EQ(*e.context().page, 0u);
    EXPECT_NE(std::string(e.what()).find("page 0"), std::string::npos);
  }
  // Without checksums the (otherwise intact) file opens: an empty file.
  EXPECT_EQ(Reader(bad_crc, {.checksums = ChecksumPolicy::none()}).scans().size(), 0u);

  Reader r(invalid_cv);  // the XML is fine...
  ASSERT_EQ(r.scans().size(), 1u);
  try {
    r.open_points(0);  // ...its section header is not
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("section id 182"), std::string::npos);
    EXPECT_EQ(*e.context().physical_offset, 48u);
    EXPECT_EQ(e.context().element, "/data3D/0/points");
  }
  EXPECT_THROW(r.verify(), Error);

  Reader z(zero_invalid);
  EXPECT_EQ(z.scans()[0].point_count, 0u);
  EXPECT_EQ(z.scans()[0].prototype.size(), 6u);  // xyz + nor:normalX/Y/Z
  try {
    z.open_points(0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(*e.context().physical_offset, 0u);
  }
}

TEST(E57Corpus, EmptyAndZeroPointFilesAreValid) {
  COLOC_REQUIRE_DATA(empty, "e57/libE57Format-test-data/self/empty.e57");
  COLOC_REQUIRE_DATA(zero, "e57/libE57Format-test-data/self/ZeroPoints.e57");
  Reader e(empty);
  EXPECT_EQ(e.info().guid, "Empty File GUID");
  EXPECT_EQ(e.scans().size(), 0u);
  EXPECT_EQ(e.images().size(), 0u);
  EXPECT_NO_THROW(e.verify());
  Reader z(zero);
  ASSERT_EQ(z.scans().size(), 1u);
  PointStream s = z.open_points(0);
  PointBuffer b;
  EXPECT_EQ(s.read(b, 100), 0u);
  EXPECT_EQ(b.size, 0u);
  EXPECT_NO_THROW(z.verify());
}

}  // namespace
}  // namespace coloc::e57
