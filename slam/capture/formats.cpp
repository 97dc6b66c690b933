#include "slam/capture/formats.hpp"

#include <algorithm>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "slam/capture/bytes.hpp"
#include "slam/core/error.hpp"

namespace coloc::capture {
namespace {

constexpr std::uint32_t kCaptureTimingId = 0x80000001u;
constexpr std::size_t kMetaPrefix = 12;  // uvc_meta_buf: u64 ns, u16 sof, u8 length, u8 flags
constexpr std::uint8_t kHeaderHasPts = 0x04;
constexpr std::uint8_t kHeaderHasScr = 0x08;

void check_size(std::span<const std::uint8_t> bytes, std::size_t needed, const char* what) {
  if (bytes.size() < needed)
    throw Error(std::string(what) + " frame of " + std::to_string(bytes.size()) +
                " bytes, expected " + std::to_string(needed) + " (truncated buffer?)");
}

}  // namespace

std::string fourcc_name(std::uint32_t code) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((code >> (8 * i)) & 0xff);
    if (c < 0x20 || c > 0x7e) {
      char buf[16];
      std::snprintf(buf, sizeof(buf), "0x%08x", code);
      return buf;
    }
    s += c;
  }
  return s;
}

std::size_t frame_bytes(std::uint32_t code, int width, int height) {
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (code == kFourccZ16 || code == kFourccYuyv) return pixels * 2;
  if (code == kFourccRgb24 || code == kFourccBgr24) return pixels * 3;
  if (code == kFourccGrey || code == kFourccY8i) return pixels;
  return 0;
}

cv::Mat decode_z16(std::span<const std::uint8_t> bytes, int width, int height, int stride) {
  const std::size_t row = static_cast<std::size_t>(stride > 0 ? stride : width * 2);
  check_size(bytes,
             row * static_cast<std::size_t>(height - 1) + static_cast<std::size_t>(width) * 2,
             "Z16");
  cv::Mat out(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y)
    std::memcpy(out.ptr<std::uint16_t>(y), bytes.data() + row * static_cast<std::size_t>(y),
                static_cast<std::size_t>(width) * 2);
  return out;
}

cv::Mat decode_color(std::span<const std::uint8_t> bytes, std::uint32_t code, int width, int height,
                     int stride) {
  const int bpp = code == kFourccYuyv ? 2 : 3;
  if (code != kFourccYuyv && code != kFourccRgb24 && code != kFourccBgr24)
    throw Error("colour format " + fourcc_name(code) + " is not supported (YUYV, RGB3, BGR3)");
  const std::size_t row = static_cast<std::size_t>(stride > 0 ? stride : width * bpp);
  check_size(bytes,
             row * static_cast<std::size_t>(height - 1) + static_cast<std::size_t>(width * bpp),
             fourcc_name(code).c_str());
  // OpenCV only reads the buffer: the const_cast makes a header, never a write.
  const cv::Mat in(height, width, bpp == 2 ? CV_8UC2 : CV_8UC3,
                   const_cast<std::uint8_t*>(bytes.data()), row);
  cv::Mat out;
  if (code == kFourccYuyv)
    cv::cvtColor(in, out, cv::COLOR_YUV2BGR_YUYV);
  else if (code == kFourccRgb24)
    cv::cvtColor(in, out, cv::COLOR_RGB2BGR);
  else
    out = in.clone();
  return out;
}

std::vector<std::uint8_t> encode_yuyv(const cv::Mat& bgr) {
  if (bgr.type() != CV_8UC3 || bgr.cols % 2 != 0)
    throw Error("encode_yuyv: needs an 8UC3 image of even width");
  // BT.601 video range, what UVC cameras send and OpenCV's YUYV decoder expects.
  auto luma = [](const cv::Vec3b& p) { return 16.0 + 0.257 * p[2] + 0.504 * p[1] + 0.098 * p[0]; };
  auto u = [](const cv::Vec3b& p) { return 128.0 - 0.148 * p[2] - 0.291 * p[1] + 0.439 * p[0]; };
  auto v = [](const cv::Vec3b& p) { return 128.0 + 0.439 * p[2] - 0.368 * p[1] - 0.071 * p[0]; };
  auto byte = [](double x) { return static_cast<std::uint8_t>(std::clamp(x + 0.5, 0.0, 255.0)); };
  std::vector<std::uint8_t> out(static_cast<std::size_t>(bgr.total()) * 2);
  std::size_t k = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const auto* p = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr.cols; x += 2) {
      out[k++] = byte(luma(p[x]));
      out[k++] = byte((u(p[x]) + u(p[x + 1])) / 2);
      out[k++] = byte(luma(p[x + 1]));
      out[k++] = byte((v(p[x]) + v(p[x + 1])) / 2);
    }
  }
  return out;
}

FrameMetadata parse_uvc_metadata(std::span<const std::uint8_t> bytes) {
  using detail::read_le;
  FrameMetadata m;
  m.host_ns = read_le<std::uint64_t>(bytes, 0, "UVC metadata ns");
  m.usb_sof = read_le<std::uint16_t>(bytes, 8, "UVC metadata sof");
  const std::size_t length = read_le<std::uint8_t>(bytes, 10, "UVC metadata length");
  if (kMetaPrefix + length > bytes.size())
    throw Error("UVC metadata: header length " + std::to_string(length) + " runs past the " +
                    std::to_string(bytes.size()) + "-byte buffer",
                {.offset = 10});
  const auto header = bytes.subspan(kMetaPrefix, length);
  if (length >= 2) {
    const std::uint8_t info = header[1];
    if ((info & kHeaderHasPts) && length >= 6) m.pts = read_le<std::uint32_t>(header, 2, "PTS");
    // Intel's blocks follow the standard fields (2 + PTS 4 + SCR 6 bytes).
    std::size_t at = 2 + ((info & kHeaderHasPts) ? 4 : 0) + ((info & kHeaderHasScr) ? 6 : 0);
    while (at + 8 <= length) {
      const auto id = read_le<std::uint32_t>(header, at, "metadata block id");
      const auto size = read_le<std::uint32_t>(header, at + 4, "metadata block size");
      if (at + 8 + size > length)
        throw Error("UVC metadata: block 0x" + fourcc_name(id) + " of " + std::to_string(size) +
                        " bytes runs past the header",
                    {.offset = kMetaPrefix + at + 4});
      if (id == kCaptureTimingId && size >= 24) {
        const std::size_t p = at + 8;  // version, flags, counter, sensor ts, readout, exposure
        m.frame_counter = read_le<std::uint32_t>(header, p + 8, "frame counter");
        m.sensor_timestamp_us = read_le<std::uint32_t>(header, p + 12, "sensor timestamp");
        m.exposure_us = read_le<std::uint32_t>(header, p + 20, "exposure");
      }
      at += 8 + size;
    }
  }
  return m;
}

std::vector<std::uint8_t> encode_uvc_metadata(const FrameMetadata& m) {
  using detail::append_le;
  std::vector<std::uint8_t> header;
  header.push_back(0);  // bLength, set below
  header.push_back(static_cast<std::uint8_t>(0x80 | kHeaderHasPts | kHeaderHasScr));
  append_le<std::uint32_t>(header, m.pts.value_or(0));
  for (int i = 0; i < 6; ++i)
    header.push_back(0);  // SCR: not used by us
  append_le<std::uint32_t>(header, kCaptureTimingId);
  append_le<std::uint32_t>(header, 32);  // version .. pipe latency: 8 u32
  const std::uint32_t fields[8] = {1,
                                   0x7,
                                   m.frame_counter.value_or(0),
                                   m.sensor_timestamp_us.value_or(0),
                                   0,
                                   m.exposure_us.value_or(0),
                                   0,
                                   0};
  for (std::uint32_t f : fields)
    append_le(header, f);
  header[0] = static_cast<std::uint8_t>(header.size());
  std::vector<std::uint8_t> out;
  append_le<std::uint64_t>(out, m.host_ns);
  append_le<std::uint16_t>(out, m.usb_sof);
  out.push_back(static_cast<std::uint8_t>(header.size()));
  out.push_back(0);
  out.insert(out.end(), header.begin(), header.end());
  return out;
}

double SensorClock::seconds(std::uint32_t timestamp_us) {
  // The signed 32-bit difference unwraps the counter and tolerates the small steps back of two
  // streams sharing one clock.
  if (last_) total_us_ += static_cast<std::int32_t>(timestamp_us - *last_);
  last_ = timestamp_us;
  return static_cast<double>(total_us_) * 1e-6;
}

}  // namespace coloc::capture
