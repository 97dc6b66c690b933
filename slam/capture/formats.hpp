#pragma once
// The pixel and metadata formats a D4xx camera sends over V4L2, decoded from their bytes.
//
// Z16: little-endian uint16 per pixel in depth units (D4xx: 1 mm by default). YUYV: 4:2:2 packed
// (Y0 U Y1 V). UVC metadata (V4L2_META_FMT_UVC, "UVCH"): the kernel's uvc_meta_buf (u64 ns,
// u16 sof, u8 length, u8 flags) then the UVC payload header (length bytes: bLength,
// bmHeaderInfo, optional 4-byte PTS and 6-byte SCR) and, on D4xx, Intel's metadata blocks
// (u32 type id, u32 size, payload), of which the capture-timing block (0x80000001) carries the
// frame counter and the sensor timestamp (microseconds on the camera's clock).
#include <cstddef>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <span>
#include <string>

namespace coloc::capture {

// V4L2 four-character codes, as <linux/videodev2.h> builds them.
constexpr std::uint32_t fourcc(char a, char b, char c, char d) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(a)) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(b)) << 8) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(c)) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(d)) << 24);
}
constexpr std::uint32_t kFourccZ16 = fourcc('Z', '1', '6', ' ');
constexpr std::uint32_t kFourccYuyv = fourcc('Y', 'U', 'Y', 'V');
constexpr std::uint32_t kFourccRgb24 = fourcc('R', 'G', 'B', '3');
constexpr std::uint32_t kFourccBgr24 = fourcc('B', 'G', 'R', '3');
constexpr std::uint32_t kFourccGrey = fourcc('G', 'R', 'E', 'Y');
constexpr std::uint32_t kFourccY8i = fourcc('Y', '8', 'I', ' ');
constexpr std::uint32_t kFourccY12i = fourcc('Y', '1', '2', 'I');
constexpr std::uint32_t kFourccUvcMeta = fourcc('U', 'V', 'C', 'H');

// "Z16 ", "YUYV", or 0x... for codes that are not printable.
std::string fourcc_name(std::uint32_t code);

// Bytes of one frame of `code` at width x height (0 for formats we do not stream).
std::size_t frame_bytes(std::uint32_t code, int width, int height);

// Z16 bytes -> CV_16UC1 (a copy; `stride` 0 means width * 2). Throws coloc::Error when the
// buffer is shorter than the frame.
cv::Mat decode_z16(std::span<const std::uint8_t> bytes, int width, int height, int stride = 0);
// YUYV / RGB24 / BGR24 bytes -> CV_8UC3 BGR. Throws coloc::Error on a short buffer or another
// format.
cv::Mat decode_color(std::span<const std::uint8_t> bytes, std::uint32_t code, int width, int height,
                     int stride = 0);
// BGR -> YUYV bytes (what the camera sends), for replay descriptions and tests.
std::vector<std::uint8_t> encode_yuyv(const cv::Mat& bgr);

struct FrameMetadata {
  std::uint64_t host_ns = 0;         // uvc_meta_buf.ns: host clock (CLOCK_MONOTONIC) at SOF
  std::uint16_t usb_sof = 0;         // USB frame number
  std::optional<std::uint32_t> pts;  // UVC presentation time stamp (device clock ticks)
  // Intel capture-timing block, when present.
  std::optional<std::uint32_t> frame_counter;
  std::optional<std::uint32_t> sensor_timestamp_us;  // camera clock, wraps at 2^32 us
  std::optional<std::uint32_t> exposure_us;
};

// Parses one UVC metadata buffer. Throws coloc::Error naming the byte offset when a length
// field points past the buffer; unknown Intel blocks are skipped.
FrameMetadata parse_uvc_metadata(std::span<const std::uint8_t> bytes);

// Builds the bytes parse_uvc_metadata reads (a 12-byte UVC header with PTS and SCR, then one
// capture-timing block): what a D4xx sends, for replay descriptions and tests.
std::vector<std::uint8_t> encode_uvc_metadata(const FrameMetadata& metadata);

// Unwraps the 32-bit microsecond sensor clock into seconds since its first sample (steps of
// less than 35 minutes between calls, either way).
class SensorClock {
 public:
  double seconds(std::uint32_t timestamp_us);

 private:
  std::optional<std::uint32_t> last_;
  std::int64_t total_us_ = 0;
};

}  // namespace coloc::capture
