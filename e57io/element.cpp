#include "e57io/element.hpp"

#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <pugixml.hpp>
#include <sstream>

#include "e57io/error.hpp"

namespace coloc::e57 {
namespace {

constexpr const char* kE57Namespace = "http://www.astm.org/COMMIT/E57/2010-e57-v1.0";

struct ParseContext {
  const std::string& file;
  Error fail(const std::string& msg, const std::string& path) const {
    return Error(msg, {.file = file, .element = path});
  }
};

std::string trimmed(const char* s) {
  std::string v(s);
  const auto b = v.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = v.find_last_not_of(" \t\r\n");
  return v.substr(b, e - b + 1);
}

std::int64_t parse_int(const char* text, std::int64_t fallback, const ParseContext& ctx,
                       const std::string& path, const char* what) {
  const std::string s = trimmed(text);
  if (s.empty()) return fallback;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (errno != 0 || end != s.c_str() + s.size()) {
    throw ctx.fail(std::string("bad integer '") + s + "' for " + what, path);
  }
  return v;
}

std::uint64_t parse_uint(const char* text, const ParseContext& ctx, const std::string& path,
                         const char* what) {
  const std::int64_t v = parse_int(text, 0, ctx, path, what);
  if (v < 0) throw ctx.fail(std::string("negative ") + what, path);
  return static_cast<std::uint64_t>(v);
}

double parse_double(const char* text, double fallback, const ParseContext& ctx,
                    const std::string& path, const char* what) {
  const std::string s = trimmed(text);
  if (s.empty()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);  // accepts "1e+008", "inf", "nan"
  if (end != s.c_str() + s.size()) {
    throw ctx.fail(std::string("bad number '") + s + "' for " + what, path);
  }
  return v;
}

ElementType parse_type(const char* type, const ParseContext& ctx, const std::string& path) {
  static constexpr std::pair<const char*, ElementType> kTypes[] = {
      {"Structure", ElementType::kStructure},
      {"Vector", ElementType::kVector},
      {"CompressedVector", ElementType::kCompressedVector},
      {"Integer", ElementType::kInteger},
      {"ScaledInteger", ElementType::kScaledInteger},
      {"Float", ElementType::kFloat},
      {"String", ElementType::kString},
      {"Blob", ElementType::kBlob}};
  for (const auto& [name, t] : kTypes) {
    if (std::strcmp(name, type) == 0) return t;
  }
  throw ctx.fail(std::string("unknown element type '") + type + "'", path);
}

std::string text_of(const pugi::xml_node& node) {
  std::string s;
  for (const pugi::xml_node& c : node.children()) {
    if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) s += c.value();
  }
  return s;
}

void parse_element(const pugi::xml_node& node, Element& e, const ParseContext& ctx, int depth) {
  if (depth > 64) throw ctx.fail("elements nested too deeply", e.path);
  const pugi::xml_attribute type_attr = node.attribute("type");
  if (!type_attr) throw ctx.fail("element has no 'type' attribute", e.path);
  e.type = parse_type(type_attr.value(), ctx, e.path);
  const std::string text = text_of(node);
  const std::string& p = e.path;
  switch (e.type) {
    case ElementType::kInteger:
    case ElementType::kScaledInteger:
      e.int_minimum =
          parse_int(node.attribute("minimum").value(), e.int_minimum, ctx, p, "minimum");
      e.int_maximum =
          parse_int(node.attribute("maximum").value(), e.int_maximum, ctx, p, "maximum");
      e.int_value = parse_int(text.c_str(), 0, ctx, p, "value");
      if (e.type == ElementType::kScaledInteger) {
        e.scale = parse_double(node.attribute("scale").value(), 1.0, ctx, p, "scale");
        e.offset = parse_double(node.attribute("offset").value(), 0.0, ctx, p, "offset");
        // Every decoded value is int * scale + offset: a zero or non-finite scale turns all of
        // them into 0 or NaN while the file still "reads".
        if (!std::isfinite(e.scale) || e.scale == 0.0) {
          throw ctx.fail("ScaledInteger scale must be finite and non-zero, got '" +
                             std::string(node.attribute("scale").value()) + "'",
                         p);
        }
        if (!std::isfinite(e.offset)) throw ctx.fail("ScaledInteger offset must be finite", p);
      }
      if (e.int_minimum > e.int_maximum) throw ctx.fail("minimum > maximum", p);
      break;
    case ElementType::kFloat: {
      e.single_precision = std::strcmp(node.attribute("precision").value(), "single") == 0;
      const double lim = e.single_precision ? FLT_MAX : DBL_MAX;
      e.float_minimum = parse_double(node.attribute("minimum").value(), -lim, ctx, p, "minimum");
      e.float_maximum = parse_double(node.attribute("maximum").value(), lim, ctx, p, "maximum");
      e.float_value = parse_double(text.c_str(), 0.0, ctx, p, "value");
      break;
    }
    case ElementType::kString:
      e.string_value = text;
      break;
    case ElementType::kBlob:
      e.file_offset = parse_uint(node.attribute("fileOffset").value(), ctx, p, "fileOffset");
      e.length = parse_uint(node.attribute("length").value(), ctx, p, "length");
      break;
    case ElementType::kCompressedVector:
      e.file_offset = parse_uint(node.attribute("fileOffset").value(), ctx, p, "fileOffset");
      e.record_count = parse_uint(node.attribute("recordCount").value(), ctx, p, "recordCount");
      break;
    case ElementType::kVector:
      e.allow_heterogeneous =
          std::strcmp(node.attribute("allowHeterogeneousChildren").value(), "1") == 0;
      break;
    case ElementType::kStructure:
      break;
  }
  const bool container = e.type == ElementType::kStructure || e.type == ElementType::kVector ||
                         e.type == ElementType::kCompressedVector;
  if (!container) return;
  std::size_t index = 0;
  for (const pugi::xml_node& c : node.children()) {
    if (c.type() != pugi::node_element) continue;
    Element child;
    child.name = c.name();
    child.path = p + "/" + (e.type == ElementType::kVector ? std::to_string(index) : child.name);
    parse_element(c, child, ctx, depth + 1);
    e.children.push_back(std::move(child));
    ++index;
  }
  if (e.type == ElementType::kCompressedVector) {
    const Element* proto = e.find("prototype");
    if (proto == nullptr) throw ctx.fail("compressed vector has no prototype", p);
  }
}

std::string format_double(double v, bool single) {
  char buf[40];
  std::snprintf(buf, sizeof buf, single ? "%.9g" : "%.17g", v);
  return buf;
}

void write_element(pugi::xml_node parent, const Element& e) {
  pugi::xml_node n = parent.append_child(e.name.c_str());
  n.append_attribute("type") = to_string(e.type);
  switch (e.type) {
    case ElementType::kInteger:
    case ElementType::kScaledInteger:
      if (e.int_minimum != std::numeric_limits<std::int64_t>::min()) {
        n.append_attribute("minimum") = std::to_string(e.int_minimum).c_str();
      }
      if (e.int_maximum != std::numeric_limits<std::int64_t>::max()) {
        n.append_attribute("maximum") = std::to_string(e.int_maximum).c_str();
      }
      if (e.type == ElementType::kScaledInteger) {
        n.append_attribute("scale") = format_double(e.scale, false).c_str();
        n.append_attribute("offset") = format_double(e.offset, false).c_str();
      }
      n.text() = std::to_string(e.int_value).c_str();
      break;
    case ElementType::kFloat: {
      n.append_attribute("precision") = e.single_precision ? "single" : "double";
      const double lim = e.single_precision ? FLT_MAX : DBL_MAX;
      if (e.float_minimum != -lim) {
        n.append_attribute("minimum") = format_double(e.float_minimum, e.single_precision).c_str();
      }
      if (e.float_maximum != lim) {
        n.append_attribute("maximum") = format_double(e.float_maximum, e.single_precision).c_str();
      }
      n.text() = format_double(e.float_value, e.single_precision).c_str();
      break;
    }
    case ElementType::kString: {
      // CDATA cannot contain "]]>": split it across two sections.
      std::string rest = e.string_value;
      std::size_t at;
      while ((at = rest.find("]]>")) != std::string::npos) {
        n.append_child(pugi::node_cdata).set_value(rest.substr(0, at + 2).c_str());
        rest = rest.substr(at + 2);
      }
      n.append_child(pugi::node_cdata).set_value(rest.c_str());
      break;
    }
    case ElementType::kBlob:
      n.append_attribute("fileOffset") = std::to_string(e.file_offset).c_str();
      n.append_attribute("length") = std::to_string(e.length).c_str();
      break;
    case ElementType::kCompressedVector:
      n.append_attribute("fileOffset") = std::to_string(e.file_offset).c_str();
      n.append_attribute("recordCount") = std::to_string(e.record_count).c_str();
      break;
    case ElementType::kVector:
      n.append_attribute("allowHeterogeneousChildren") = e.allow_heterogeneous ? "1" : "0";
      break;
    case ElementType::kStructure:
      break;
  }
  for (const Element& c : e.children)
    write_element(n, c);
}

}  // namespace

const char* to_string(ElementType type) {
  switch (type) {
    case ElementType::kStructure:
      return "Structure";
    case ElementType::kVector:
      return "Vector";
    case ElementType::kCompressedVector:
      return "CompressedVector";
    case ElementType::kInteger:
      return "Integer";
    case ElementType::kScaledInteger:
      return "ScaledInteger";
    case ElementType::kFloat:
      return "Float";
    case ElementType::kString:
      return "String";
    case ElementType::kBlob:
      return "Blob";
  }
  return "?";
}

const Element* Element::find(std::string_view child_name) const {
  for (const Element& c : children) {
    if (c.name == child_name) return &c;
  }
  return nullptr;
}

const Element* Element::find_path(std::string_view slash_path) const {
  const Element* e = this;
  while (e != nullptr && !slash_path.empty()) {
    const auto slash = slash_path.find('/');
    e = e->find(slash_path.substr(0, slash));
    slash_path =
        slash == std::string_view::npos ? std::string_view{} : slash_path.substr(slash + 1);
  }
  return e;
}

double Element::number() const {
  switch (type) {
    case ElementType::kInteger:
      return static_cast<double>(int_value);
    case ElementType::kScaledInteger:
      return static_cast<double>(int_value) * scale + offset;
    case ElementType::kFloat:
      return float_value;
    default:
      throw Error(std::string("expected a number, found a ") + to_string(type), {.element = path});
  }
}

Element Element::make_integer(std::string name, std::int64_t value) {
  Element e;
  e.name = std::move(name);
  e.type = ElementType::kInteger;
  e.int_value = value;
  return e;
}

Element Element::make_float(std::string name, double value) {
  Element e;
  e.name = std::move(name);
  e.type = ElementType::kFloat;
  e.float_value = value;
  return e;
}

Element Element::make_string(std::string name, std::string value) {
  Element e;
  e.name = std::move(name);
  e.type = ElementType::kString;
  e.string_value = std::move(value);
  return e;
}

Element Element::make_structure(std::string name) {
  Element e;
  e.name = std::move(name);
  e.type = ElementType::kStructure;
  return e;
}

Element parse_xml(std::string_view xml, const std::string& file) {
  const ParseContext ctx{file};
  pugi::xml_document doc;
  const pugi::xml_parse_result r =
      doc.load_buffer(xml.data(), xml.size(), pugi::parse_default, pugi::encoding_utf8);
  if (!r) {
    throw Error(std::string("XML section does not parse: ") + r.description() + " at XML byte " +
                    std::to_string(r.offset),
                {.file = file});
  }
  const pugi::xml_node root = doc.document_element();
  if (std::strcmp(root.name(), "e57Root") != 0) {
    throw ctx.fail(std::string("root element is '") + root.name() + "', expected 'e57Root'", "/");
  }
  Element e;
  e.name = "e57Root";
  e.path = "";
  for (const pugi::xml_attribute& a : root.attributes()) {
    const std::string an = a.name();
    if (an.rfind("xmlns:", 0) == 0) e.namespaces.emplace_back(an.substr(6), a.value());
  }
  parse_element(root, e, ctx, 0);
  if (e.type != ElementType::kStructure) throw ctx.fail("e57Root is not a Structure", "/");
  return e;
}

std::string to_xml(const Element& root) {
  pugi::xml_document doc;
  pugi::xml_node decl = doc.append_child(pugi::node_declaration);
  decl.append_attribute("version") = "1.0";
  decl.append_attribute("encoding") = "UTF-8";
  Element r = root;
  r.name = "e57Root";
  write_element(doc, r);
  pugi::xml_node n = doc.document_element();
  n.insert_attribute_after("xmlns", n.attribute("type")) = kE57Namespace;
  for (const auto& [prefix, uri] : root.namespaces) {
    n.append_attribute(("xmlns:" + prefix).c_str()) = uri.c_str();
  }
  std::ostringstream out;
  doc.save(out, "  ", pugi::format_default, pugi::encoding_utf8);
  return out.str();
}

}  // namespace coloc::e57
