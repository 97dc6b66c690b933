// The file layer: CRC-32C, logical/physical mapping, paged writing and reading, checksum policy.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <random>

#include "e57io/crc32c.hpp"
#include "e57io/paged_file.hpp"
#include "tests/testing/data.hpp"

namespace coloc::e57 {
namespace {

std::vector<std::uint8_t> random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> v(n);
  for (auto& b : v)
    b = static_cast<std::uint8_t>(rng());
  return v;
}

TEST(Crc32c, KnownVectors) {
  const char* s = "123456789";
  EXPECT_EQ(crc32c(s, 9), 0xE3069283u);
  EXPECT_EQ(crc32c_portable(s, 9), 0xE3069283u);
  // RFC 3720 B.4: 32 bytes of zeros -> 0x8A9136AA; of 0xFF -> 0x62A8AB43.
  std::uint8_t buf[32] = {};
  EXPECT_EQ(crc32c(buf, 32), 0x8A9136AAu);
  std::memset(buf, 0xFF, 32);
  EXPECT_EQ(crc32c_portable(buf, 32), 0x62A8AB43u);
}

TEST(Crc32c, HardwareAndPortableAgreeAndContinue) {
  const auto data = random_bytes(5000, 1);
  for (std::size_t n : {0u, 1u, 7u, 8u, 9u, 1020u, 4999u}) {
    EXPECT_EQ(crc32c(data.data(), n), crc32c_portable(data.data(), n)) << n;
  }
  std::uint32_t three[3];
  crc32c_x3(data.data(), data.data() + 1020, data.data() + 2040, 1020, three);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(three[k], crc32c_portable(data.data() + 1020 * k, 1020)) << k;
  }
  const std::uint32_t whole = crc32c(data.data(), data.size());
  EXPECT_EQ(crc32c(data.data() + 1000, 4000, crc32c(data.data(), 1000)), whole);
}

TEST(PagedFile, LogicalPhysicalMapping) {
  EXPECT_EQ(logical_to_physical(0), 0u);
  EXPECT_EQ(logical_to_physical(1019), 1019u);
  EXPECT_EQ(logical_to_physical(1020), 1024u);
  EXPECT_EQ(physical_to_logical(2048 + 5), 2040u + 5);
  for (std::uint64_t l : {0ull, 48ull, 1019ull, 1020ull, 123456ull}) {
    EXPECT_EQ(physical_to_logical(logical_to_physical(l)), l);
  }
}

TEST(PagedFile, WriteReadPatchAcrossPages) {
  const auto dir = testing::temp_dir("e57_paged");
  const auto path = dir / "p.e57";
  const auto data = random_bytes(5000, 2);
  {
    PagedWriter w(path);
    EXPECT_EQ(w.logical_position(), 48u);
    w.write(data);
    const std::uint8_t patch[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    w.patch(1016, patch);  // crosses the page 0 / page 1 boundary, both already flushed
    FileHeader h;
    h.xml_physical_offset = 48;
    h.xml_logical_length = 0;
    EXPECT_EQ(w.finish(h), 5 * 1024u);  // 5048 logical bytes -> 5 pages
  }
  EXPECT_EQ(std::filesystem::file_size(path), 5 * 1024u);
  PagedReader r(path);
  EXPECT_EQ(r.header().physical_length, 5 * 1024u);
  r.verify_all_pages();
  std::vector<std::uint8_t> back(5000);
  r.read(48, back);
  for (std::size_t i = 0; i < back.size(); ++i) {
    const bool in_patch = i >= 1016 - 48 && i < 1016 - 48 + 8;
    const auto want = in_patch ? static_cast<std::uint8_t>(i - (1016 - 48) + 1) : data[i];
    ASSERT_EQ(back[i], want) << i;
  }
  // Reading past the end is an error naming the offset.
  std::vector<std::uint8_t> tail(100);
  EXPECT_THROW(r.read(5 * 1020 - 10, tail), Error);
}

TEST(PagedFile, CorruptPageNamedAndPolicyRespected) {
  const auto dir = testing::temp_dir("e57_paged_bad");
  const auto path = dir / "bad.e57";
  {
    PagedWriter w(path);
    w.write(random_bytes(3000, 3));
    w.finish(FileHeader{.xml_physical_offset = 48});
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(2 * 1024 + 100);  // page 2
    f.put('\x5A');
  }
  PagedReader r(path);
  std::vector<std::uint8_t> buf(10);
  r.read(100, buf);  // page 0 fine
  try {
    r.read(2 * 1020 + 50, buf);
    FAIL() << "expected a checksum error";
  } catch (const Error& e) {
    ASSERT_TRUE(e.context().page.has_value());
    EXPECT_EQ(*e.context().page, 2u);
    EXPECT_EQ(*e.context().physical_offset, 2048u);
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos);
  }
  PagedReader unchecked(path, ChecksumPolicy::none());
  EXPECT_NO_THROW(unchecked.read(2 * 1020 + 50, buf));
  EXPECT_THROW(unchecked.verify_all_pages(), Error);
}

TEST(PagedFile, SampledPolicyIsDeterministicFraction) {
  const ChecksumPolicy p = ChecksumPolicy::sampled(0.25);
  int n = 0;
  for (std::uint64_t page = 0; page < 10000; ++page)
    n += p.wants(page) ? 1 : 0;
  EXPECT_NEAR(n, 2500, 200);
  EXPECT_EQ(p.wants(17), ChecksumPolicy::sampled(0.25).wants(17));
  EXPECT_THROW(ChecksumPolicy::sampled(1.5).check(), Error);
}

TEST(PagedFile, RejectsNonE57AndTruncated) {
  const auto dir = testing::temp_dir("e57_paged_hdr");
  {
    std::ofstream f(dir / "text.e57", std::ios::binary);
    f << std::string(2048, 'x');
  }
  EXPECT_THROW(PagedReader(dir / "text.e57"), Error);
  {
    PagedWriter w(dir / "t.e57");
    w.write(random_bytes(3000, 4));
    w.finish(FileHeader{.xml_physical_offset = 48});
  }
  std::filesystem::resize_file(dir / "t.e57", 2048);
  try {
    PagedReader r(dir / "t.e57");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos);
  }
  EXPECT_THROW(PagedReader(dir / "missing.e57"), Error);
}

}  // namespace
}  // namespace coloc::e57
