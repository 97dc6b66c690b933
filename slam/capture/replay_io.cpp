// The replay description on disk: DIR/replay.yaml and DIR/frames/<node>_<frame>.bin.
#include <charconv>
#include <fstream>
#include <opencv2/core.hpp>

#include "slam/capture/replay.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/yaml_text.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

void write_bytes(const fs::path& path, std::span<const std::uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) throw Error("cannot write", {.file = path.string()});
}

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  check_input_file(path, "replay frame");  // a FIFO or a device never ends
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot read replay frame", {.file = path.string()});
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_formats(cv::FileStorage& fs, const std::vector<NodeFormat>& formats) {
  fs << "formats"
     << "[";
  for (const NodeFormat& f : formats) {
    fs << "{"
       << "fourcc" << fourcc_name(f.fourcc) << "sizes"
       << "[";
    for (const auto& s : f.sizes)
      fs << "{"
         << "width" << s.width << "height" << s.height << "fps" << s.fps << "}";
    fs << "]"
       << "}";
  }
  fs << "]";
}

std::uint32_t parse_fourcc(std::string s, const fs::path& file) {
  if (!s.empty() && s.size() < 4) s.resize(4, ' ');  // YAML drops the trailing space of "Z16 "
  if (s.size() != 4)
    throw Error("fourcc must have 4 characters: '" + s + "'",
                {.file = file.string(), .field = "fourcc"});
  return fourcc(s[0], s[1], s[2], s[3]);
}

std::vector<NodeFormat> read_formats(const cv::FileNode& node, const fs::path& file) {
  std::vector<NodeFormat> out;
  for (const auto& f : node["formats"]) {
    NodeFormat nf{.fourcc = parse_fourcc(static_cast<std::string>(f["fourcc"]), file)};
    for (const auto& s : f["sizes"]) {
      NodeFormat::Size size{static_cast<int>(s["width"]), static_cast<int>(s["height"]), {}};
      for (const auto& r :
           s["fps"])  // element by element: OpenCV's vector reader trips -Wnull-dereference
        size.fps.push_back(static_cast<double>(r));
      nf.sizes.push_back(size);
    }
    out.push_back(std::move(nf));
  }
  return out;
}

void write_node(cv::FileStorage& fs, const ReplayNode& n, std::size_t k, const fs::path& dir) {
  fs << "{"
     << "device" << n.info.device.string() << "name" << n.info.name << "index" << n.info.index
     << "usb_path" << n.info.usb_path << "vendor" << int{n.info.vendor} << "product"
     << int{n.info.product} << "serial" << n.info.serial << "speed" << n.info.speed << "open_errno"
     << n.open_errno << "xu_errno" << n.xu_errno << "unplug_after"
     << (n.unplug_after ? static_cast<int>(*n.unplug_after) : -1);
  write_formats(fs, n.formats);
  if (n.frames_mode)
    fs << "frames_mode"
       << "{"
       << "fourcc" << fourcc_name(n.frames_mode->fourcc) << "width" << n.frames_mode->width
       << "height" << n.frames_mode->height << "fps" << n.frames_mode->fps << "}";
  fs << "frames"
     << "[";
  for (std::size_t i = 0; i < n.frames.size(); ++i) {
    const std::string file = std::to_string(k) + "_" + std::to_string(i) + ".bin";
    write_bytes(dir / "frames" / file, n.frames[i].bytes);
    fs << "{"
       << "file" << file << "sequence" << static_cast<int>(n.frames[i].sequence) << "timestamp_ns"
       << std::to_string(n.frames[i].timestamp_ns) << "}";
  }
  fs << "]"
     << "tables"
     << "[";
  for (const auto& [id, bytes] : n.tables) {
    const std::string file = std::to_string(k) + "_table" + std::to_string(id) + ".bin";
    write_bytes(dir / "frames" / file, bytes);
    fs << "{"
       << "id" << int{id} << "file" << file << "}";
  }
  fs << "]"
     << "}";
}

// A frame's kernel timestamp (ns, a decimal string: more digits than a double keeps); an error
// naming the frame, not std::stoll's bare "stoll", when it is not an int64.
std::int64_t timestamp_ns(const std::string& text, const fs::path& file, const std::string& field) {
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec == std::errc::result_out_of_range)
    throw Error("'" + text + "' is out of range (a 64-bit integer of nanoseconds)",
                {.file = file.string(), .field = field});
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    throw Error("'" + text + "' is not an integer of nanoseconds",
                {.file = file.string(), .field = field});
  return value;
}

ReplayNode read_node(const cv::FileNode& n, const fs::path& dir, const fs::path& file) {
  ReplayNode r;
  r.info = {.device = static_cast<std::string>(n["device"]),
            .name = static_cast<std::string>(n["name"]),
            .index = static_cast<int>(n["index"]),
            .usb_path = static_cast<std::string>(n["usb_path"]),
            .vendor = static_cast<std::uint16_t>(static_cast<int>(n["vendor"])),
            .product = static_cast<std::uint16_t>(static_cast<int>(n["product"])),
            .serial = static_cast<std::string>(n["serial"]),
            .speed = static_cast<std::string>(n["speed"])};
  r.open_errno = static_cast<int>(n["open_errno"]);
  r.xu_errno = static_cast<int>(n["xu_errno"]);
  if (const int u = static_cast<int>(n["unplug_after"]); u >= 0) r.unplug_after = u;
  r.formats = read_formats(n, file);
  if (!n["frames_mode"].empty()) {
    const auto m = n["frames_mode"];
    r.frames_mode = StreamMode{parse_fourcc(static_cast<std::string>(m["fourcc"]), file),
                               static_cast<int>(m["width"]), static_cast<int>(m["height"]),
                               static_cast<double>(m["fps"])};
  }
  std::size_t k = 0;
  for (const auto& f : n["frames"]) {
    const std::string field = "frames[" + std::to_string(k++) + "].timestamp_ns";
    r.frames.push_back({read_bytes(dir / "frames" / static_cast<std::string>(f["file"])),
                        static_cast<std::uint32_t>(static_cast<int>(f["sequence"])),
                        timestamp_ns(static_cast<std::string>(f["timestamp_ns"]), file, field)});
  }
  for (const auto& t : n["tables"])
    r.tables[static_cast<std::uint16_t>(static_cast<int>(t["id"]))] =
        read_bytes(dir / "frames" / static_cast<std::string>(t["file"]));
  return r;
}

}  // namespace

void save_replay(const ReplayDescription& d, const fs::path& dir) {
  fs::create_directories(dir / "frames");
  const fs::path file = dir / "replay.yaml";
  cv::FileStorage fs(file.string(), cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw Error("cannot write", {.file = file.string()});
  fs << "realtime" << static_cast<int>(d.realtime) << "nodes"
     << "[";
  for (std::size_t k = 0; k < d.nodes.size(); ++k)
    write_node(fs, d.nodes[k], k, dir);
  fs << "]";
}

namespace {

ReplayDescription read_replay_text(const fs::path& dir) {
  const fs::path file = dir / "replay.yaml";
  ReplayDescription d;
  // Through the YAML guard (OpenCV's reader can loop forever); a replay lists every frame.
  const std::string text =
      read_yaml_text(file, "replay description", {.max_bytes = std::size_t{256} << 20});
  try {
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!fs.isOpened()) throw Error("cannot open replay description", {.file = file.string()});
    d.realtime = static_cast<int>(fs["realtime"]) != 0;
    for (const auto& n : fs["nodes"])
      d.nodes.push_back(read_node(n, dir, file));
  } catch (const cv::Exception& e) {
    throw Error("malformed replay description: " + e.msg, {.file = file.string()});
  } catch (const std::invalid_argument&) {
    throw Error("malformed number in replay description",
                {.file = file.string(), .field = "timestamp_ns"});
  }
  if (d.nodes.empty())
    throw Error("replay description without nodes", {.file = file.string(), .field = "nodes"});
  return d;
}

}  // namespace

ReplayDescription load_replay(const fs::path& dir) {
  return read_naming_file(dir / "replay.yaml", "replay description",
                          [&] { return read_replay_text(dir); });
}

}  // namespace coloc::capture
