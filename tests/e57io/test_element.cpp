// The element tree: XML parsing of every element type, defaults, errors with element paths,
// extension namespaces, and serialization back to XML.

#include <gtest/gtest.h>

#include "e57io/element.hpp"
#include "e57io/error.hpp"

namespace coloc::e57 {
namespace {

constexpr const char* kXml = R"(<?xml version="1.0"?>
<e57Root type="Structure" xmlns="http://www.astm.org/COMMIT/E57/2010-e57-v1.0"
         xmlns:ext="http://example.com/ext">
  <guid type="String"><![CDATA[{abc}]]></guid>
  <n type="Integer" minimum="-5" maximum="10">7</n>
  <empty type="Integer"/>
  <s type="ScaledInteger" minimum="0" maximum="1000" scale="0.5" offset="2">10</s>
  <f type="Float" precision="single">1.5e+000</f>
  <data3D type="Vector" allowHeterogeneousChildren="1">
    <vectorChild type="Structure">
      <points type="CompressedVector" fileOffset="48" recordCount="3">
        <prototype type="Structure"><cartesianX type="Float"/></prototype>
        <codecs type="Vector" allowHeterogeneousChildren="1"/>
      </points>
      <ext:thing type="Blob" fileOffset="100" length="7"/>
    </vectorChild>
  </data3D>
</e57Root>)";

TEST(Element, ParsesAllTypesAndPaths) {
  const Element root = parse_xml(kXml, "mem.e57");
  ASSERT_EQ(root.namespaces.size(), 1u);
  EXPECT_EQ(root.namespaces[0].first, "ext");
  EXPECT_EQ(root.find("guid")->string_value, "{abc}");
  const Element* n = root.find("n");
  EXPECT_EQ(n->int_value, 7);
  EXPECT_EQ(n->int_minimum, -5);
  EXPECT_EQ(n->int_maximum, 10);
  EXPECT_EQ(root.find("empty")->int_value, 0);
  EXPECT_DOUBLE_EQ(root.find("s")->number(), 10 * 0.5 + 2);
  EXPECT_TRUE(root.find("f")->single_precision);
  EXPECT_DOUBLE_EQ(root.find("f")->number(), 1.5);
  const Element* points = root.find_path("data3D/vectorChild/points");
  ASSERT_NE(points, nullptr);
  EXPECT_EQ(points->path, "/data3D/0/points");
  EXPECT_EQ(points->record_count, 3u);
  EXPECT_EQ(points->file_offset, 48u);
  const Element* blob = root.find_path("data3D/vectorChild/ext:thing");
  ASSERT_NE(blob, nullptr);
  EXPECT_EQ(blob->type, ElementType::kBlob);
  EXPECT_EQ(blob->length, 7u);
  EXPECT_THROW(root.find("guid")->number(), Error);
}

TEST(Element, RoundTripsThroughXml) {
  const Element root = parse_xml(kXml, "mem.e57");
  const Element again = parse_xml(to_xml(root), "mem2.e57");
  EXPECT_EQ(again.namespaces, root.namespaces);
  EXPECT_EQ(again.find("n")->int_minimum, -5);
  EXPECT_DOUBLE_EQ(again.find("s")->scale, 0.5);
  EXPECT_DOUBLE_EQ(again.find("s")->offset, 2.0);
  EXPECT_TRUE(again.find("f")->single_precision);
  EXPECT_EQ(again.find_path("data3D/vectorChild/ext:thing")->file_offset, 100u);
  // Strings holding the CDATA terminator survive.
  Element r = Element::make_structure("e57Root");
  r.children.push_back(Element::make_string("s", "a]]>b<&"));
  EXPECT_EQ(parse_xml(to_xml(r), "x").find("s")->string_value, "a]]>b<&");
}

TEST(Element, ErrorsNameTheElement) {
  const char* bad_number = R"(<e57Root type="Structure"><a type="Structure">
    <b type="Integer">12x</b></a></e57Root>)";
  try {
    parse_xml(bad_number, "f.e57");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().element, "/a/b");
    EXPECT_EQ(e.context().file, "f.e57");
  }
  EXPECT_THROW(parse_xml(R"(<e57Root type="Structure"><a type="Bogus"/></e57Root>)", "f"), Error);
  EXPECT_THROW(parse_xml(R"(<e57Root type="Structure"><a/></e57Root>)", "f"), Error);
  EXPECT_THROW(parse_xml("<notE57 type=\"Structure\"/>", "f"), Error);
  EXPECT_THROW(parse_xml("<e57Root type=\"Structure\">", "f"), Error);
  EXPECT_THROW(parse_xml(R"(<e57Root type="Structure"><c type="CompressedVector" fileOffset="1"
    recordCount="1"/></e57Root>)",
                         "f"),
               Error);  // no prototype
}

}  // namespace
}  // namespace coloc::e57
