// Compressed-vector packet handling on a hand-built section: an index packet and an empty
// (ignored) packet between data packets, and a bit-packed stream whose records straddle packet
// boundaries at non-byte bit positions. Also a section that ends too early.

#include <gtest/gtest.h>

#include <cstring>

#include "e57io/compressed_vector.hpp"
#include "e57io/paged_file.hpp"
#include "tests/testing/data.hpp"

namespace coloc::e57 {
namespace {

std::vector<std::uint8_t> packet(std::uint8_t type,
                                 const std::vector<std::vector<std::uint8_t>>& streams) {
  std::vector<std::uint8_t> p;
  if (type == 0) {  // index packet with no entries: 16-byte header
    p.assign(16, 0);
  } else if (type == 2) {  // empty packet
    p.assign(8, 0);
  } else {
    p.assign(6 + 2 * streams.size(), 0);
    p[4] = static_cast<std::uint8_t>(streams.size());
    for (std::size_t i = 0; i < streams.size(); ++i) {
      p[6 + 2 * i] = static_cast<std::uint8_t>(streams[i].size());
      p.insert(p.end(), streams[i].begin(), streams[i].end());
    }
    while (p.size() % 4 != 0)
      p.push_back(0);
  }
  p[0] = type;
  const auto len = static_cast<std::uint16_t>(p.size() - 1);
  std::memcpy(&p[2], &len, 2);
  return p;
}

// Ten-bit values packed LSB first.
std::vector<std::uint8_t> pack10(const std::vector<std::uint32_t>& values) {
  std::vector<std::uint8_t> out((values.size() * 10 + 7) / 8, 0);
  std::size_t bit = 0;
  for (std::uint32_t v : values) {
    for (int b = 0; b < 10; ++b, ++bit) {
      if ((v >> b) & 1u) out[bit / 8] |= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  }
  return out;
}

std::vector<std::uint8_t> floats(const std::vector<float>& v) {
  std::vector<std::uint8_t> out(v.size() * 4);
  std::memcpy(out.data(), v.data(), out.size());
  return out;
}

Element test_vector(std::uint64_t records) {
  Element cv;
  cv.name = "points";
  cv.path = "/test/points";
  cv.type = ElementType::kCompressedVector;
  cv.file_offset = 48;
  cv.record_count = records;
  Element proto = Element::make_structure("prototype");
  Element a = Element::make_integer("a", 0);
  a.int_minimum = 0;
  a.int_maximum = 1023;
  Element b = Element::make_float("b", 0);
  b.single_precision = true;
  proto.children = {a, b};
  cv.children.push_back(proto);
  return cv;
}

std::filesystem::path build_file(const std::string& name, bool truncate_last) {
  const std::vector<std::uint32_t> a = {1, 2, 3, 1000, 1023};
  const auto a_bytes = pack10(a);  // 7 bytes; record 2 straddles bytes 2-3
  const auto b_bytes = floats({0.5f, -1.5f, 2.5f, 1e6f, -0.0f});
  std::vector<std::uint8_t> section;
  auto add = [&](const std::vector<std::uint8_t>& p) {
    section.insert(section.end(), p.begin(), p.end());
  };
  add(packet(0, {}));
  add(packet(1, {{a_bytes.begin(), a_bytes.begin() + 3}, {b_bytes.begin(), b_bytes.begin() + 8}}));
  add(packet(2, {}));
  if (!truncate_last) {
    add(packet(1, {{a_bytes.begin() + 3, a_bytes.end()}, {b_bytes.begin() + 8, b_bytes.end()}}));
  }
  const auto path = testing::temp_dir("e57_packets_" + name) / "p.e57";
  PagedWriter w(path);
  std::uint8_t head[32] = {1};
  const std::uint64_t length = 32 + section.size();
  const std::uint64_t data = 48 + 32;
  std::memcpy(head + 8, &length, 8);
  std::memcpy(head + 16, &data, 8);
  w.write(head);
  w.write(section);
  const std::string xml = "<e57Root type=\"Structure\"/>";
  FileHeader h;
  h.xml_physical_offset = w.physical_position();
  h.xml_logical_length = xml.size();
  w.write({reinterpret_cast<const std::uint8_t*>(xml.data()), xml.size()});
  w.finish(h);
  return path;
}

TEST(E57Packets, SkipsIndexAndEmptyPacketsAndJoinsStreams) {
  PagedReader file(build_file("ok", false));
  CompressedVectorReader cv(file, test_vector(5));
  ASSERT_EQ(cv.channel_count(), 2u);
  EXPECT_EQ(cv.channel_codec(0).bits, 10u);
  std::int64_t a[5] = {};
  double b[5] = {};
  // Two records, then three: the second read needs the second data packet for both streams.
  Sink sinks[2] = {{Sink::Type::kInt64, a}, {Sink::Type::kDouble, b}};
  EXPECT_EQ(cv.read(2, sinks), 2u);
  sinks[0].data = a + 2;
  sinks[1].data = b + 2;
  EXPECT_EQ(cv.read(10, sinks), 3u);
  EXPECT_EQ(cv.read(10, sinks), 0u);
  EXPECT_EQ(std::vector<std::int64_t>(a, a + 5), (std::vector<std::int64_t>{1, 2, 3, 1000, 1023}));
  EXPECT_EQ(std::vector<double>(b, b + 5), (std::vector<double>{0.5, -1.5, 2.5, 1e6, -0.0}));
}

TEST(E57Packets, ReadingOnlyOneStreamWorks) {
  PagedReader file(build_file("one", false));
  CompressedVectorReader cv(file, test_vector(5));
  double b[5] = {};
  Sink sinks[2] = {{}, {Sink::Type::kDouble, b}};
  EXPECT_EQ(cv.read(5, sinks), 5u);
  EXPECT_EQ(b[4], -0.0);
  EXPECT_EQ(b[3], 1e6);
}

TEST(E57Packets, SectionEndingEarlyIsAnError) {
  PagedReader file(build_file("short", true));
  CompressedVectorReader cv(file, test_vector(5));
  std::int64_t a[5];
  double b[5];
  Sink sinks[2] = {{Sink::Type::kInt64, a}, {Sink::Type::kDouble, b}};
  EXPECT_EQ(cv.read(2, sinks), 2u);
  try {
    cv.read(3, sinks);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("ends before"), std::string::npos);
    EXPECT_EQ(e.context().element, "/test/points");
    EXPECT_TRUE(e.context().logical_offset.has_value());
  }
}

TEST(E57Packets, RecordCountLargerThanSectionIsRejected) {
  PagedReader file(build_file("count", false));
  EXPECT_THROW(CompressedVectorReader(file, test_vector(1000)), Error);
}

}  // namespace
}  // namespace coloc::e57
