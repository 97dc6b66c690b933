#pragma once
// The E57 element tree (ASTM E2807 section 8): the XML section parsed into plain values.
// Every element of the file is kept, including extension elements ("nor:normalX") whose
// namespace prefixes are recorded on the root, so a tree can be inspected or written back.

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace coloc::e57 {

enum class ElementType {
  kStructure,
  kVector,
  kCompressedVector,
  kInteger,
  kScaledInteger,
  kFloat,
  kString,
  kBlob
};

const char* to_string(ElementType type);

struct Element {
  std::string name;  // XML tag, with prefix for extensions; "vectorChild" etc. inside Vectors
  std::string path;  // "/data3D/0/points": for error messages (Vector children by index)
  ElementType type = ElementType::kStructure;

  // Integer and ScaledInteger: value is the raw integer; ScaledInteger means raw*scale+offset.
  std::int64_t int_value = 0;
  std::int64_t int_minimum = std::numeric_limits<std::int64_t>::min();
  std::int64_t int_maximum = std::numeric_limits<std::int64_t>::max();
  double scale = 1.0;
  double offset = 0.0;

  // Float.
  double float_value = 0.0;
  bool single_precision = false;
  double float_minimum = -std::numeric_limits<double>::max();
  double float_maximum = std::numeric_limits<double>::max();

  std::string string_value;  // String

  // Blob: physical offset of its 16-byte section header and its length in bytes.
  // CompressedVector: physical offset of its section header and its record count.
  std::uint64_t file_offset = 0;
  std::uint64_t length = 0;
  std::uint64_t record_count = 0;

  bool allow_heterogeneous = false;  // Vector
  std::vector<Element> children;     // Structure, Vector; CompressedVector: prototype, codecs

  // Root only: extension namespaces declared as xmlns:prefix="uri".
  std::vector<std::pair<std::string, std::string>> namespaces;

  // Child by name (first match), nullptr if absent.
  const Element* find(std::string_view child_name) const;
  // Descends "a/b/c"; nullptr if any step is absent.
  const Element* find_path(std::string_view slash_path) const;

  // Numeric value: Integer -> value, ScaledInteger -> raw*scale+offset, Float -> value.
  // Throws Error naming the path for other types.
  double number() const;

  static Element make_integer(std::string name, std::int64_t value);
  static Element make_float(std::string name, double value);
  static Element make_string(std::string name, std::string value);
  static Element make_structure(std::string name);
};

// Parses the XML section. `file` is used in error messages only. Throws Error naming the element
// path for malformed XML, unknown types or bad numbers.
Element parse_xml(std::string_view xml, const std::string& file);

// Serializes a tree rooted at "e57Root" (adds the E57 default namespace and root's prefixes).
std::string to_xml(const Element& root);

}  // namespace coloc::e57
