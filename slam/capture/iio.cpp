#include "slam/capture/iio.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <fstream>
#include <regex>

#include "slam/core/error.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::string s;
  std::getline(in, s);
  return s;
}

void write_text(const fs::path& p, const std::string& value) {
  std::ofstream out(p);
  out << value;
  out.flush();
  if (!out)
    throw Error("cannot write '" + value +
                    "' (permissions: install the RealSense udev rules or "
                    "run as a member of the group owning /sys/bus/iio)",
                {.file = p.string()});
}

}  // namespace

IioChannel parse_iio_type(const std::string& name, int index, const std::string& type) {
  static const std::regex kType(R"((le|be):([su])(\d+)/(\d+)(?:X\d+)?>>(\d+))");
  std::smatch m;
  if (!std::regex_match(type, m, kType))
    throw Error("malformed iio scan type '" + type + "'", {.field = name});
  IioChannel c{.name = name, .index = index};
  c.big_endian = m[1] == "be";
  c.is_signed = m[2] == "s";
  c.bits = std::stoi(m[3]);
  c.storage_bits = std::stoi(m[4]);
  c.shift = std::stoi(m[5]);
  if (c.bits > c.storage_bits || c.storage_bits % 8 != 0 || c.storage_bits > 64 || c.bits == 0)
    throw Error("impossible iio scan type '" + type + "'", {.field = name});
  return c;
}

std::size_t iio_layout(std::vector<IioChannel>& channels) {
  std::sort(channels.begin(), channels.end(),
            [](const IioChannel& a, const IioChannel& b) { return a.index < b.index; });
  std::size_t at = 0, align = 1;
  for (IioChannel& c : channels) {
    const std::size_t bytes = static_cast<std::size_t>(c.storage_bits / 8);
    at = (at + bytes - 1) / bytes * bytes;
    c.offset = at;
    at += bytes;
    align = std::max(align, bytes);
  }
  return (at + align - 1) / align * align;
}

std::int64_t iio_value(const std::uint8_t* scan, const IioChannel& c) {
  const int bytes = c.storage_bits / 8;
  std::uint64_t raw = 0;
  for (int i = 0; i < bytes; ++i) {
    const std::uint64_t b = scan[c.offset + static_cast<std::size_t>(i)];
    raw |= c.big_endian ? b << (8 * (bytes - 1 - i)) : b << (8 * i);
  }
  raw >>= c.shift;
  if (c.bits < 64) raw &= (std::uint64_t{1} << c.bits) - 1;
  if (c.is_signed && c.bits < 64 && (raw >> (c.bits - 1)) & 1)
    return static_cast<std::int64_t>(raw) - (std::int64_t{1} << c.bits);  // sign extension
  return static_cast<std::int64_t>(raw);
}

std::vector<IioSensor> find_iio_imu(const fs::path& root, const std::string& usb_path) {
  std::vector<IioSensor> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    const std::string name = read_text(e.path() / "name");
    if (name != "accel_3d" && name != "gyro_3d") continue;
    const fs::path real = fs::canonical(e.path(), ec);
    if (!usb_path.empty() && real.string().rfind(usb_path, 0) != 0) continue;
    out.push_back({e.path(), fs::path("/dev") / e.path().filename(), name});
  }
  std::sort(out.begin(), out.end(),
            [](const IioSensor& a, const IioSensor& b) { return a.name < b.name; });
  return out;
}

IioReader::IioReader(const IioSensor& sensor, int buffer_length) : sensor_(sensor) {
  prefix_ = sensor.name == "gyro_3d" ? "in_anglvel" : "in_accel";
  const fs::path scan = sensor.sysfs / "scan_elements";
  write_text(sensor.sysfs / "buffer" / "enable", "0");
  for (const std::string axis : {"_x", "_y", "_z"}) {
    const std::string ch = prefix_ + axis;
    write_text(scan / (ch + "_en"), "1");
    channels_.push_back(parse_iio_type(ch, std::stoi(read_text(scan / (ch + "_index"))),
                                       read_text(scan / (ch + "_type"))));
  }
  write_text(scan / "in_timestamp_en", "1");
  channels_.push_back(parse_iio_type("in_timestamp",
                                     std::stoi(read_text(scan / "in_timestamp_index")),
                                     read_text(scan / "in_timestamp_type")));
  scan_bytes_ = iio_layout(channels_);
  try {
    scale_ = std::stod(read_text(sensor.sysfs / (prefix_ + "_scale")));
  } catch (const std::exception&) {
    throw Error("unreadable scale", {.file = (sensor.sysfs / (prefix_ + "_scale")).string()});
  }
  if (fs::exists(sensor.sysfs / "current_timestamp_clock"))
    write_text(sensor.sysfs / "current_timestamp_clock", "monotonic");  // V4L2's clock
  write_text(sensor.sysfs / "buffer" / "length", std::to_string(buffer_length));
  write_text(sensor.sysfs / "buffer" / "enable", "1");
  fd_ = ::open(sensor.device.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0)
    throw Error(std::string("cannot open: ") + std::strerror(errno),
                {.file = sensor.device.string()});
}

IioReader::~IioReader() {
  if (fd_ >= 0) ::close(fd_);
  try {
    write_text(sensor_.sysfs / "buffer" / "enable", "0");
  } catch (const Error&) {  // the camera may be gone: nothing to switch off
  }
}

std::vector<IioSample> IioReader::read(int timeout_ms) {
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0) return {};
  std::uint8_t buf[4096];
  const ssize_t n = ::read(fd_, buf, sizeof(buf));
  if (n == 0) at_end_ = true;
  if (n <= 0) return {};
  pending_.insert(pending_.end(), buf, buf + n);
  std::vector<IioSample> out;
  std::size_t at = 0;
  for (; at + scan_bytes_ <= pending_.size(); at += scan_bytes_) {
    const std::uint8_t* s = pending_.data() + at;
    IioSample sample;
    sample.timestamp = static_cast<double>(iio_value(s, channels_[3])) * 1e-9;
    for (int k = 0; k < 3; ++k)
      sample.value[k] =
          static_cast<double>(iio_value(s, channels_[static_cast<std::size_t>(k)])) * scale_;
    out.push_back(sample);
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(at));
  return out;
}

ImuStream::ImuStream(const IioSensor& accel, const IioSensor& gyro)
    : accel_(accel), gyro_(gyro), queue_(4096) {
  thread_ = std::thread([this] { run(); });
}

ImuStream::~ImuStream() {
  stop();
}

void ImuStream::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  queue_.close();
}

std::vector<dataset::ImuSample> ImuStream::take() {
  std::vector<dataset::ImuSample> out;
  while (auto s = queue_.pop_for(std::chrono::milliseconds(0)))
    out.push_back(*s);
  return out;
}

void ImuStream::run() {
  std::deque<IioSample> accel, gyro;
  while (!stop_ && !(accel_.at_end() && gyro_.at_end())) {
    for (const IioSample& s : accel_.read(5))
      accel.push_back(s);
    for (const IioSample& s : gyro_.read(5))
      gyro.push_back(s);
    // A gyro sample is emitted once accelerometer samples bracket its time.
    while (!gyro.empty() && accel.size() >= 2) {
      const IioSample& g = gyro.front();
      if (g.timestamp < accel[0].timestamp) {
        gyro.pop_front();  // before the first accelerometer sample: cannot interpolate
        continue;
      }
      if (g.timestamp > accel[1].timestamp) {
        accel.pop_front();
        continue;
      }
      const double span = accel[1].timestamp - accel[0].timestamp;
      const double w = span > 0 ? (g.timestamp - accel[0].timestamp) / span : 0.0;
      const dataset::ImuSample s{g.timestamp, g.value,
                                 (1 - w) * accel[0].value + w * accel[1].value};
      if (queue_.size() < queue_.capacity())
        queue_.push(s);
      else
        ++dropped_;  // the consumer is behind
      gyro.pop_front();
    }
  }
}

}  // namespace coloc::capture
