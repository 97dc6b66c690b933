#include "registration/align/point_file.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <sstream>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::registration::align {
namespace {

enum class Scalar : std::uint8_t { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

std::size_t scalar_size(Scalar s) {
  switch (s) {
    case Scalar::kI8:
    case Scalar::kU8:
      return 1;
    case Scalar::kI16:
    case Scalar::kU16:
      return 2;
    case Scalar::kI32:
    case Scalar::kU32:
    case Scalar::kF32:
      return 4;
    case Scalar::kF64:
      return 8;
  }
  return 0;
}

bool is_integer(Scalar s) {
  return s != Scalar::kF32 && s != Scalar::kF64;
}

// One value at `p` (file byte order `swap`ped to ours when big-endian) as a double.
double decode(const char* p, Scalar s, bool swap) {
  char b[8];
  const std::size_t n = scalar_size(s);
  std::memcpy(b, p, n);
  if (swap) std::reverse(b, b + n);
  switch (s) {
    case Scalar::kI8:
      return static_cast<std::int8_t>(b[0]);
    case Scalar::kU8:
      return static_cast<std::uint8_t>(b[0]);
    case Scalar::kI16: {
      std::int16_t v;
      std::memcpy(&v, b, 2);
      return v;
    }
    case Scalar::kU16: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return v;
    }
    case Scalar::kI32: {
      std::int32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case Scalar::kU32: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case Scalar::kF32: {
      float v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case Scalar::kF64: {
      double v;
      std::memcpy(&v, b, 8);
      return v;
    }
  }
  return 0.0;
}

// The 32 bits of a packed colour (PCL's rgb float or rgba uint), as stored.
std::uint32_t packed_bits(const char* p, bool swap) {
  char b[4];
  std::memcpy(b, p, 4);
  if (swap) std::reverse(b, b + 4);
  std::uint32_t v;
  std::memcpy(&v, b, 4);
  return v;
}

std::uint8_t channel(double v, Scalar s) {
  // Integer channels of 8 bits as they are, of 16 bits scaled down; float channels in [0, 1].
  double x = v;
  if (s == Scalar::kU16 || s == Scalar::kI16) x = v / 257.0;
  if (!is_integer(s)) x = v * 255.0;
  return static_cast<std::uint8_t>(std::clamp(std::round(x), 0.0, 255.0));
}

std::array<std::uint8_t, 3> unpack_rgb(std::uint32_t v) {
  return {static_cast<std::uint8_t>((v >> 16) & 0xffu), static_cast<std::uint8_t>((v >> 8) & 0xffu),
          static_cast<std::uint8_t>(v & 0xffu)};
}

// liblzf's format (PCD binary_compressed): a control byte below 32 starts a run of ctrl + 1
// literal bytes; otherwise a back reference of length (ctrl >> 5) + 2 (7 means a further
// length byte), at distance ((ctrl & 31) << 8) + next byte + 1. Every read and write is bounds
// checked: a damaged block is an error, never a read outside the buffers.
bool lzf_decompress(const std::uint8_t* in, std::size_t in_size, std::uint8_t* out,
                    std::size_t out_size) {
  std::size_t i = 0, o = 0;
  while (i < in_size) {
    const unsigned ctrl = in[i++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1;
      if (i + run > in_size || o + run > out_size) return false;
      std::memcpy(out + o, in + i, run);
      i += run;
      o += run;
      continue;
    }
    std::size_t length = ctrl >> 5;
    if (length == 7) {
      if (i >= in_size) return false;
      length += in[i++];
    }
    if (i >= in_size) return false;
    const std::size_t distance = ((ctrl & 31u) << 8) + in[i++] + 1;
    length += 2;
    if (distance > o || o + length > out_size) return false;
    for (std::size_t k = 0; k < length; ++k, ++o)
      out[o] = out[o - distance];  // byte by byte: the source may overlap the destination
  }
  return o == out_size;
}

std::vector<std::string> split(const std::string& line) {
  std::istringstream s(line);
  std::vector<std::string> words;
  for (std::string w; s >> w;)
    words.push_back(w);
  return words;
}

}  // namespace

struct PointFileReader::Impl {
  struct Field {
    std::string name;
    Scalar type = Scalar::kF32;
    int count = 1;                    // PCD COUNT (values in this field)
    bool list = false;                // PLY list property
    Scalar count_type = Scalar::kU8;  // of a list's length
    std::size_t offset = 0;           // in a fixed-size record
  };
  enum class Encoding : std::uint8_t { kAscii, kLittle, kBig, kCompressed };

  std::filesystem::path path;
  std::ifstream in;
  PointFileFormat format = PointFileFormat::kPly;
  Encoding encoding = Encoding::kAscii;
  std::vector<Field> fields;
  std::size_t record_size = 0;  // binary records without list properties
  bool has_list = false;
  int x = -1, y = -1, z = -1, r = -1, g = -1, b = -1, packed = -1;
  std::uint64_t count = 0, consumed = 0, dropped = 0;
  std::int64_t line = 0;                  // ASCII: the line being read (for errors)
  std::vector<char> record;               // one binary record
  std::vector<std::size_t> value_at;      // where each field's value is in the current record
  std::vector<std::uint8_t> columns;      // binary_compressed: the whole decompressed cloud
  std::vector<std::size_t> column_start;  // per field, in `columns`

  [[noreturn]] void fail(const std::string& message, ErrorContext context = {}) const {
    context.file = path.string();
    throw Error(message, context);
  }
  std::uint64_t offset() {
    return static_cast<std::uint64_t>(std::max<std::streamoff>(in.tellg(), 0));
  }

  int index_of(std::initializer_list<const char*> names) const {
    for (const char* n : names)
      for (std::size_t i = 0; i < fields.size(); ++i)
        if (fields[i].name == n) return static_cast<int>(i);
    return -1;
  }

  void find_fields(const char* what) {
    x = index_of({"x"});
    y = index_of({"y"});
    z = index_of({"z"});
    if (x < 0 || y < 0 || z < 0) fail(std::string(what) + " has no x, y and z", {.field = "x"});
    for (int i : {x, y, z})
      if (fields[i].list) fail("a coordinate is a list property", {.field = fields[i].name});
    r = index_of({"red", "diffuse_red", "r"});
    g = index_of({"green", "diffuse_green", "g"});
    b = index_of({"blue", "diffuse_blue", "b"});
    if (r < 0 || g < 0 || b < 0 || fields[r].list || fields[g].list || fields[b].list)
      r = g = b = -1;
    packed = index_of({"rgb", "rgba"});
    if (packed >= 0 && scalar_size(fields[packed].type) != 4) packed = -1;
    std::size_t at = 0;
    for (Field& f : fields) {
      f.offset = at;
      at += scalar_size(f.type) * static_cast<std::size_t>(f.count);
      has_list = has_list || f.list;
    }
    record_size = at;
  }

  // ---- PLY header -------------------------------------------------------------------------

  static Scalar ply_scalar(const std::string& t, const Impl& self) {
    if (t == "char" || t == "int8") return Scalar::kI8;
    if (t == "uchar" || t == "uint8") return Scalar::kU8;
    if (t == "short" || t == "int16") return Scalar::kI16;
    if (t == "ushort" || t == "uint16") return Scalar::kU16;
    if (t == "int" || t == "int32") return Scalar::kI32;
    if (t == "uint" || t == "uint32") return Scalar::kU32;
    if (t == "float" || t == "float32") return Scalar::kF32;
    if (t == "double" || t == "float64") return Scalar::kF64;
    self.fail("unknown PLY type '" + t + "'", {.line = self.line});
  }

  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Field> properties;
  };

  void read_ply_header() {
    std::string text;
    std::vector<Element> elements;
    bool ended = false;
    while (std::getline(in, text)) {
      ++line;
      if (!text.empty() && text.back() == '\r') text.pop_back();
      const auto w = split(text);
      if (line == 1) {
        if (text != "ply") fail("not a PLY file (first line is not 'ply')", {.line = 1});
        continue;
      }
      if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
      if (w[0] == "end_header") {
        ended = true;
        break;
      }
      if (w[0] == "format") {
        if (w.size() < 2) fail("format without a name", {.field = "format", .line = line});
        if (w[1] == "ascii")
          encoding = Encoding::kAscii;
        else if (w[1] == "binary_little_endian")
          encoding = Encoding::kLittle;
        else if (w[1] == "binary_big_endian")
          encoding = Encoding::kBig;
        else
          fail("unknown PLY format '" + w[1] + "'", {.field = "format", .line = line});
      } else if (w[0] == "element") {
        if (w.size() != 3)
          fail("expected 'element NAME COUNT'", {.field = "element", .line = line});
        Element e;
        e.name = w[1];
        try {
          std::size_t used = 0;
          e.count = std::stoull(w[2], &used);
          if (used != w[2].size()) throw std::invalid_argument(w[2]);
        } catch (const std::exception&) {
          fail("element count '" + w[2] + "' is not a number",
               {.field = "element " + w[1], .line = line});
        }
        elements.push_back(e);
      } else if (w[0] == "property") {
        if (elements.empty())
          fail("a property before any element", {.field = "property", .line = line});
        Field f;
        if (w.size() == 5 && w[1] == "list") {
          f.list = true;
          f.count_type = ply_scalar(w[2], *this);
          f.type = ply_scalar(w[3], *this);
          f.name = w[4];
        } else if (w.size() == 3) {
          f.type = ply_scalar(w[1], *this);
          f.name = w[2];
        } else {
          fail("expected 'property TYPE NAME' or 'property list T T NAME'",
               {.field = "property", .line = line});
        }
        elements.back().properties.push_back(f);
      } else {
        fail("unknown PLY header line '" + text + "'", {.line = line});
      }
    }
    if (!ended) fail("the PLY header has no end_header", {.field = "end_header"});
    const auto vertex = std::find_if(elements.begin(), elements.end(),
                                     [](const Element& e) { return e.name == "vertex"; });
    if (vertex == elements.end()) fail("the PLY file has no vertex element", {.field = "vertex"});
    // Elements before the vertices (rare) are skipped record by record.
    for (auto e = elements.begin(); e != vertex; ++e) {
      fields = e->properties;
      find_offsets_only();
      for (std::uint64_t k = 0; k < e->count; ++k)
        skip_record();
    }
    fields = vertex->properties;
    count = vertex->count;
    find_fields("the PLY vertex element");
  }

  void find_offsets_only() {
    std::size_t at = 0;
    has_list = false;
    for (Field& f : fields) {
      f.offset = at;
      at += scalar_size(f.type);
      has_list = has_list || f.list;
    }
    record_size = at;
  }

  void skip_record() {
    if (encoding == Encoding::kAscii) {
      std::string text;
      if (!std::getline(in, text)) fail("the file ends inside an element", {.line = line});
      ++line;
      return;
    }
    record.resize(8);
    for (const Field& f : fields) {
      std::uint64_t n = 1;
      if (f.list) {
        read_bytes(record.data(), scalar_size(f.count_type));
        n = static_cast<std::uint64_t>(
            decode(record.data(), f.count_type, encoding == Encoding::kBig));
      }
      in.seekg(static_cast<std::streamoff>(n * scalar_size(f.type)), std::ios::cur);
    }
  }

  void read_bytes(char* to, std::size_t n) {
    const std::uint64_t at = offset();
    if (!in.read(to, static_cast<std::streamsize>(n)))
      fail(
          "the file ends inside point " + std::to_string(consumed) + " of " + std::to_string(count),
          {.offset = at});
  }

  // ---- PCD header -------------------------------------------------------------------------

  void read_pcd_header() {
    std::string text;
    std::vector<std::string> names, sizes, types, counts;
    std::uint64_t width = 0, height = 1, points = 0;
    bool have_points = false;
    while (std::getline(in, text)) {
      ++line;
      if (!text.empty() && text.back() == '\r') text.pop_back();
      const auto w = split(text);
      if (w.empty() || w[0][0] == '#') continue;
      const std::vector<std::string> rest(w.begin() + 1, w.end());
      auto number = [&](const std::string& key) -> std::uint64_t {
        if (rest.size() != 1) fail("expected one number", {.field = key, .line = line});
        try {
          std::size_t used = 0;
          const std::uint64_t v = std::stoull(rest[0], &used);
          if (used == rest[0].size()) return v;
        } catch (const std::exception&) {
        }
        fail("'" + rest[0] + "' is not a count", {.field = key, .line = line});
      };
      if (w[0] == "VERSION" || w[0] == "VIEWPOINT") continue;
      if (w[0] == "FIELDS")
        names = rest;
      else if (w[0] == "SIZE")
        sizes = rest;
      else if (w[0] == "TYPE")
        types = rest;
      else if (w[0] == "COUNT")
        counts = rest;
      else if (w[0] == "WIDTH")
        width = number("WIDTH");
      else if (w[0] == "HEIGHT")
        height = number("HEIGHT");
      else if (w[0] == "POINTS") {
        points = number("POINTS");
        have_points = true;
      } else if (w[0] == "DATA") {
        if (rest.size() != 1)
          fail("expected 'DATA ascii|binary|binary_compressed'", {.field = "DATA", .line = line});
        if (rest[0] == "ascii")
          encoding = Encoding::kAscii;
        else if (rest[0] == "binary")
          encoding = Encoding::kLittle;
        else if (rest[0] == "binary_compressed")
          encoding = Encoding::kCompressed;
        else
          fail("unknown PCD data '" + rest[0] + "'", {.field = "DATA", .line = line});
        break;
      } else {
        fail("unknown PCD header line '" + text + "'", {.line = line});
      }
    }
    if (!in) fail("the PCD header has no DATA line", {.field = "DATA"});
    if (names.empty()) fail("the PCD header has no FIELDS", {.field = "FIELDS"});
    if (sizes.size() != names.size() || types.size() != names.size())
      fail("FIELDS, SIZE and TYPE name different numbers of fields", {.field = "SIZE"});
    if (!counts.empty() && counts.size() != names.size())
      fail("FIELDS and COUNT name different numbers of fields", {.field = "COUNT"});
    for (std::size_t i = 0; i < names.size(); ++i) {
      Field f;
      f.name = names[i];
      const std::string key = types[i] + sizes[i];
      if (key == "I1")
        f.type = Scalar::kI8;
      else if (key == "U1")
        f.type = Scalar::kU8;
      else if (key == "I2")
        f.type = Scalar::kI16;
      else if (key == "U2")
        f.type = Scalar::kU16;
      else if (key == "I4")
        f.type = Scalar::kI32;
      else if (key == "U4")
        f.type = Scalar::kU32;
      else if (key == "F4")
        f.type = Scalar::kF32;
      else if (key == "F8")
        f.type = Scalar::kF64;
      else
        fail("unsupported TYPE/SIZE '" + types[i] + " " + sizes[i] + "'",
             {.field = "field " + f.name});
      if (!counts.empty()) {
        try {
          f.count = std::stoi(counts[i]);
        } catch (const std::exception&) {
          f.count = 0;
        }
        if (f.count < 1) fail("COUNT must be >= 1", {.field = "field " + f.name});
      }
      fields.push_back(f);
    }
    count = have_points ? points : width * height;
    find_fields("the PCD file");
    if (encoding == Encoding::kCompressed) read_compressed();
  }

  // binary_compressed: one LZF block holding the fields one after the other (all x, then all
  // y, ...). It is decompressed whole: PCL writes it so, it cannot be streamed.
  void read_compressed() {
    std::uint32_t sizes[2];
    read_bytes(reinterpret_cast<char*>(sizes), sizeof sizes);
    const std::uint64_t expected = count * record_size;
    if (sizes[1] != expected)
      fail("binary_compressed holds " + std::to_string(sizes[1]) + " bytes where " +
               std::to_string(count) + " points need " + std::to_string(expected),
           {.field = "DATA"});
    std::vector<std::uint8_t> packed_data(sizes[0]);
    read_bytes(reinterpret_cast<char*>(packed_data.data()), packed_data.size());
    columns.resize(sizes[1]);
    if (!lzf_decompress(packed_data.data(), packed_data.size(), columns.data(), columns.size()))
      fail("the binary_compressed block is damaged (LZF)", {.field = "DATA"});
    std::size_t at = 0;
    for (const Field& f : fields) {
      column_start.push_back(at);
      at += count * scalar_size(f.type) * static_cast<std::size_t>(f.count);
    }
  }

  // ---- records ----------------------------------------------------------------------------

  // Reads the next record into (x, y, z, colour); false when it has a non-finite coordinate.
  bool next(Eigen::Vector3f& p, std::array<std::uint8_t, 3>& c) {
    if (encoding == Encoding::kAscii) return next_ascii(p, c);
    const bool swap = encoding == Encoding::kBig;
    const char* base = nullptr;
    value_at.resize(fields.size());
    if (encoding == Encoding::kCompressed) {
      for (std::size_t i = 0; i < fields.size(); ++i)
        value_at[i] = column_start[i] + consumed * scalar_size(fields[i].type) * fields[i].count;
      base = reinterpret_cast<const char*>(columns.data());
    } else if (!has_list) {
      record.resize(record_size);
      read_bytes(record.data(), record_size);
      for (std::size_t i = 0; i < fields.size(); ++i)
        value_at[i] = fields[i].offset;
      base = record.data();
    } else {
      // A vertex with list properties: field by field, lists read and set aside.
      record.clear();
      for (std::size_t i = 0; i < fields.size(); ++i) {
        const Field& f = fields[i];
        std::uint64_t n = 1;
        if (f.list) {
          char len[8];
          read_bytes(len, scalar_size(f.count_type));
          n = static_cast<std::uint64_t>(decode(len, f.count_type, swap));
        }
        value_at[i] = record.size();
        record.resize(record.size() + n * scalar_size(f.type));
        read_bytes(record.data() + value_at[i], n * scalar_size(f.type));
      }
      base = record.data();
    }
    const auto value = [&](int i) { return decode(base + value_at[i], fields[i].type, swap); };
    const double vx = value(x), vy = value(y), vz = value(z);
    if (r >= 0) {
      c = {channel(value(r), fields[r].type), channel(value(g), fields[g].type),
           channel(value(b), fields[b].type)};
    } else if (packed >= 0) {
      c = unpack_rgb(packed_bits(base + value_at[packed], swap));
    }
    p = Eigen::Vector3d(vx, vy, vz).cast<float>();
    return std::isfinite(vx) && std::isfinite(vy) && std::isfinite(vz);
  }

  bool next_ascii(Eigen::Vector3f& p, std::array<std::uint8_t, 3>& c) {
    std::string text;
    std::vector<std::string> w;
    while (w.empty()) {
      if (!std::getline(in, text))
        fail("the file ends after " + std::to_string(consumed) + " of " + std::to_string(count) +
                 " points",
             {.line = line});
      ++line;
      w = split(text);
    }
    // Where each field's first value is among the words (lists make it vary).
    value_at.resize(fields.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < fields.size(); ++i) {
      if (k >= w.size())
        fail("too few values on the line", {.field = fields[i].name, .line = line});
      if (fields[i].list) {
        const std::size_t n = static_cast<std::size_t>(std::strtoull(w[k].c_str(), nullptr, 10));
        value_at[i] = k + 1;
        k += 1 + n;
      } else {
        value_at[i] = k;
        k += static_cast<std::size_t>(fields[i].count);
      }
    }
    if (k > w.size()) fail("too few values on the line", {.line = line});
    const auto value = [&](int i) {
      const std::string& word = w[value_at[i]];
      char* end = nullptr;
      const double v = std::strtod(word.c_str(), &end);
      if (end == word.c_str() || *end != '\0')
        fail("'" + word + "' is not a number", {.field = fields[i].name, .line = line});
      return v;
    };
    const double vx = value(x), vy = value(y), vz = value(z);
    if (r >= 0) {
      c = {channel(value(r), fields[r].type), channel(value(g), fields[g].type),
           channel(value(b), fields[b].type)};
    } else if (packed >= 0) {
      // The colour's 32 bits: a TYPE U (or I) field holds them as an integer, a TYPE F field
      // as the float they make (PCL reads and writes both so).
      const std::string& word = w[value_at[packed]];
      std::uint32_t bits = 0;
      if (is_integer(fields[packed].type)) {
        bits = static_cast<std::uint32_t>(std::strtoull(word.c_str(), nullptr, 10));
      } else {
        const float f = std::strtof(word.c_str(), nullptr);
        std::memcpy(&bits, &f, 4);
      }
      c = unpack_rgb(bits);
    }
    p = Eigen::Vector3d(vx, vy, vz).cast<float>();
    return std::isfinite(vx) && std::isfinite(vy) && std::isfinite(vz);
  }
};

const char* format_name(PointFileFormat format) {
  switch (format) {
    case PointFileFormat::kE57:
      return "E57";
    case PointFileFormat::kPly:
      return "PLY";
    case PointFileFormat::kPcd:
      return "PCD";
  }
  return "?";
}

PointFileFormat detect_point_file(const std::filesystem::path& path) {
  check_input_file(path, "point cloud");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open the point cloud", {.file = path.string()});
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string start(head, static_cast<std::size_t>(in.gcount()));
  if (start.rfind("ASTM-E57", 0) == 0) return PointFileFormat::kE57;
  if (start.rfind("ply\n", 0) == 0 || start.rfind("ply\r\n", 0) == 0) return PointFileFormat::kPly;
  if (start.rfind("# .PCD", 0) == 0 || start.rfind("VERSION", 0) == 0 ||
      start.rfind("FIELDS", 0) == 0)
    return PointFileFormat::kPcd;
  throw Error("not a point cloud coloc reads (E57, PLY or PCD, told by the first bytes)",
              {.file = path.string(), .offset = 0});
}

PointFileReader::PointFileReader(const std::filesystem::path& path)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->format = detect_point_file(path);
  if (impl_->format == PointFileFormat::kE57)
    throw Error("an E57 file: read it with e57io (load_scan_cloud does)", {.file = path.string()});
  impl_->in.open(path, std::ios::binary);
  if (!impl_->in) throw Error("cannot open the point cloud", {.file = path.string()});
  if (impl_->format == PointFileFormat::kPly)
    impl_->read_ply_header();
  else
    impl_->read_pcd_header();
}

PointFileReader::~PointFileReader() = default;

PointFileFormat PointFileReader::format() const {
  return impl_->format;
}
std::uint64_t PointFileReader::points_declared() const {
  return impl_->count;
}
bool PointFileReader::has_colour() const {
  return impl_->r >= 0 || impl_->packed >= 0;
}
std::uint64_t PointFileReader::dropped() const {
  return impl_->dropped;
}

std::size_t PointFileReader::read(PointBatch& batch, std::size_t max) {
  batch.clear();
  Impl& m = *impl_;
  std::size_t n = 0;
  Eigen::Vector3f p;
  std::array<std::uint8_t, 3> c{128, 128, 128};
  while (n < max && m.consumed < m.count) {
    const bool finite = m.next(p, c);
    ++m.consumed;
    ++n;
    if (!finite) {
      ++m.dropped;
      continue;
    }
    batch.points.push_back(p);
    if (has_colour()) batch.colours.push_back(c);
  }
  return n;
}

}  // namespace coloc::registration::align
