// Scans in the formats users export (registration/align/point_file.hpp): PLY in its three
// encodings, PCD in its three, told apart by content; files written by PCL's own tools
// (pcl-tools: pcl_convert_pcd_ascii_binary, pcl_pcd2ply), a second writer beside ours; and
// damaged files named with their field, line or offset.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "registration/align/point_file.hpp"
#include "registration/align/scan_cloud.hpp"
#include "slam/core/error.hpp"
#include "slam/core/ply_writer.hpp"

namespace coloc::registration::align {
namespace {

namespace fs = std::filesystem;

fs::path temp(const std::string& name) {
  return fs::path(::testing::TempDir()) / ("point_file_" + name);
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

struct Read {
  PointBatch all;
  std::uint64_t dropped = 0;
  bool colour = false;
};

Read read_all(const fs::path& path) {
  PointFileReader reader(path);
  Read r;
  r.colour = reader.has_colour();
  PointBatch batch;
  while (reader.read(batch, 2) > 0) {  // small batches: records across batch ends
    r.all.points.insert(r.all.points.end(), batch.points.begin(), batch.points.end());
    r.all.colours.insert(r.all.colours.end(), batch.colours.begin(), batch.colours.end());
  }
  r.dropped = reader.dropped();
  return r;
}

// Three points with colours, as PlyWriter writes them (binary little-endian).
fs::path our_ply() {
  const fs::path path = temp("ours.ply");
  PlyWriter ply(path, ply_xyz_rgb(), "three points");
  ply.add(1.0f, 2.0f, 3.0f, std::uint8_t{255}, std::uint8_t{0}, std::uint8_t{0});
  ply.add(-1.5f, 0.25f, 10.0f, std::uint8_t{0}, std::uint8_t{128}, std::uint8_t{7});
  ply.add(0.0f, 0.0f, -4.0f, std::uint8_t{1}, std::uint8_t{2}, std::uint8_t{3});
  ply.commit();
  return path;
}

void expect_three(const Read& r) {
  ASSERT_EQ(r.all.points.size(), 3u);
  EXPECT_EQ(r.all.points[1], Eigen::Vector3f(-1.5f, 0.25f, 10.0f));
  EXPECT_EQ(r.all.points[2], Eigen::Vector3f(0.0f, 0.0f, -4.0f));
  ASSERT_TRUE(r.colour);
  ASSERT_EQ(r.all.colours.size(), 3u);
  EXPECT_EQ(r.all.colours[0], (std::array<std::uint8_t, 3>{255, 0, 0}));
  EXPECT_EQ(r.all.colours[1], (std::array<std::uint8_t, 3>{0, 128, 7}));
}

TEST(PointFile, OurBinaryPly) {
  const fs::path path = our_ply();
  EXPECT_EQ(detect_point_file(path), PointFileFormat::kPly);
  expect_three(read_all(path));
}

TEST(PointFile, AsciiPlyWithOtherElementsDoublesAndNormals) {
  // An element before the vertices, double coordinates, normals between, faces after.
  const fs::path path = temp("ascii.ply");
  write_text(path,
             "ply\r\nformat ascii 1.0\ncomment from a tool\nelement camera 1\nproperty float f\n"
             "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
             "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n"
             "property uchar green\nproperty uchar blue\nelement face 1\n"
             "property list uchar int vertex_indices\nend_header\n525.0\n"
             "1 2 3 0 0 1 255 0 0\n-1.5 0.25 10 0 1 0 0 128 7\n\n0 0 -4 1 0 0 1 2 3\n3 0 1 2\n");
  expect_three(read_all(path));
}

TEST(PointFile, BigEndianPlyWithAListInTheVertex) {
  const fs::path path = temp("big.ply");
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty float x\n"
         "property list uchar int tags\nproperty float y\nproperty float z\nend_header\n";
  const auto put_float = [&](float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    for (int shift = 24; shift >= 0; shift -= 8)
      out.put(static_cast<char>((bits >> shift) & 0xffu));
  };
  put_float(1.0f);
  out.put(2);  // two tags of 4 bytes
  out.write("\0\0\0\1\0\0\0\2", 8);
  put_float(2.0f);
  put_float(3.0f);
  put_float(-1.0f);
  out.put(0);  // no tags
  put_float(-2.0f);
  put_float(-3.0f);
  out.close();
  const Read r = read_all(path);
  ASSERT_EQ(r.all.points.size(), 2u);
  EXPECT_FALSE(r.colour);
  EXPECT_EQ(r.all.points[0], Eigen::Vector3f(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(r.all.points[1], Eigen::Vector3f(-1.0f, -2.0f, -3.0f));
}

// A coloured cloud as PCL writes it in ASCII: rgb as a TYPE U field, the colour's 32 bits.
const char* kPcdAscii =
    "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n"
    "TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 4\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\n"
    "DATA ascii\n1 2 3 16711680\n-1.5 0.25 10 32775\nnan nan nan 0\n0 0 -4 66051\n";

TEST(PointFile, PcdAsciiWithPackedColourAndAHole) {
  const fs::path path = temp("ascii.pcd");
  write_text(path, kPcdAscii);
  EXPECT_EQ(detect_point_file(path), PointFileFormat::kPcd);
  const Read r = read_all(path);
  EXPECT_EQ(r.dropped, 1u);  // the organized cloud's hole
  expect_three(r);
}

bool have_pcl_tools() {
  return fs::exists("/usr/bin/pcl_convert_pcd_ascii_binary") && fs::exists("/usr/bin/pcl_pcd2ply");
}

int run(const std::string& command) {
  return std::system((command + " > /dev/null 2>&1").c_str());
}

// Our PLY through PCL (pcl_ply2pcd: a PointXYZRGB cloud, rgb packed in a float), then written
// back by PCL as PCD in its three encodings and as PLY in its two: each reads as the original.
TEST(PointFile, FilesWrittenByPclsOwnTools) {
  if (!have_pcl_tools()) GTEST_SKIP() << "pcl-tools is not installed (scripts/install_deps.sh)";
  const fs::path pcd = temp("pcl.pcd");
  fs::remove(pcd);
  ASSERT_EQ(run("pcl_ply2pcd " + our_ply().string() + " " + pcd.string()), 0);
  for (const char* mode : {"0", "1", "2"}) {  // ascii, binary, binary_compressed
    const fs::path out = temp(std::string("pcl_") + mode + ".pcd");
    fs::remove(out);
    ASSERT_EQ(run("pcl_convert_pcd_ascii_binary " + pcd.string() + " " + out.string() + " " + mode),
              0);
    SCOPED_TRACE(std::string("PCD written by PCL, mode ") + mode);
    expect_three(read_all(out));
  }
  for (const char* format : {"0", "1"}) {  // ASCII and binary PLY
    const fs::path out = temp(std::string("pcl_") + format + ".ply");
    fs::remove(out);
    ASSERT_EQ(
        run("pcl_pcd2ply -format " + std::string(format) + " " + pcd.string() + " " + out.string()),
        0);
    SCOPED_TRACE(std::string("PLY written by PCL, format ") + format);
    expect_three(read_all(out));
  }
}

TEST(PointFile, TheContentDecidesNotTheName) {
  const fs::path ply_named_e57 = temp("really_a_ply.e57");
  fs::copy_file(our_ply(), ply_named_e57, fs::copy_options::overwrite_existing);
  EXPECT_EQ(detect_point_file(ply_named_e57), PointFileFormat::kPly);
  ScanCloudOptions keep_all;
  keep_all.voxel_size = 0.0;
  keep_all.stray.min_neighbours = 0;  // three points far apart are all "stray"
  const render::PointCloud cloud = load_scan_cloud(ply_named_e57, keep_all);
  EXPECT_EQ(cloud.points.size(), 3u);
  const fs::path garbage = temp("garbage.ply");
  write_text(garbage, "solid mesh\nfacet normal 0 0 1\n");
  try {
    detect_point_file(garbage);
    FAIL() << "an STL file is not a point cloud";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, garbage.string());
  }
}

void expect_error(const fs::path& path, const std::string& field) {
  try {
    read_all(path);
    FAIL() << "no error for " << path;
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, path.string()) << e.what();
    if (!field.empty()) {
      EXPECT_EQ(e.context().field, field) << e.what();
    }
  }
}

TEST(PointFile, DamagedFilesAreNamedErrors) {
  const fs::path truncated = temp("truncated.ply");
  {
    const fs::path whole_file = our_ply();
    std::string whole(fs::file_size(whole_file), '\0');
    std::ifstream(whole_file, std::ios::binary)
        .read(whole.data(), static_cast<std::streamsize>(whole.size()));
    write_text(truncated, whole.substr(0, whole.size() - 5));
  }
  try {
    read_all(truncated);
    FAIL() << "a truncated PLY must fail";
  } catch (const Error& e) {
    EXPECT_TRUE(e.context().offset.has_value()) << e.what();
  }
  const fs::path no_z = temp("no_z.ply");
  write_text(no_z,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "end_header\n1 2\n");
  expect_error(no_z, "x");
  const fs::path bad_count = temp("bad_count.ply");
  write_text(bad_count, "ply\nformat ascii 1.0\nelement vertex many\nend_header\n");
  expect_error(bad_count, "element vertex");
  const fs::path bad_number = temp("bad_number.pcd");
  write_text(bad_number,
             "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\n"
             "DATA ascii\n1 two 3\n");
  expect_error(bad_number, "y");
  const fs::path bad_lzf = temp("bad_lzf.pcd");
  {
    std::ofstream out(bad_lzf, std::ios::binary);
    out << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\n"
           "DATA binary_compressed\n";
    const std::uint32_t sizes[2] = {4, 12};
    out.write(reinterpret_cast<const char*>(sizes), sizeof sizes);
    out.write("\xff\xff\xff\xff", 4);  // a back reference before the start
  }
  expect_error(bad_lzf, "DATA");
}

}  // namespace
}  // namespace coloc::registration::align
