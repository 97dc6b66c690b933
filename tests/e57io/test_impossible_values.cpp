// Issue 17: values that parse but no scanner can produce are errors naming the element, not a
// file that "verifies" and then decodes to NaN or 0 coordinates.

#include <gtest/gtest.h>

#include <string>

#include "e57io/element.hpp"
#include "e57io/error.hpp"
#include "e57io/model.hpp"

namespace coloc::e57 {
namespace {

std::string scaled(const std::string& scale, const std::string& offset = "0") {
  return R"(<?xml version="1.0"?><e57Root type="Structure" xmlns="http://www.astm.org/COMMIT/E57/2010-e57-v1.0">
    <x type="ScaledInteger" minimum="0" maximum="1000" scale=")" +
         scale + R"(" offset=")" + offset + R"(">10</x></e57Root>)";
}

std::string error_of(const std::string& xml) {
  try {
    parse_xml(xml, "mem.e57");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(E57ImpossibleValues, ScaledIntegerScaleMustBeFiniteAndNonZero) {
  EXPECT_EQ(error_of(scaled("0.001")), "");
  EXPECT_EQ(error_of(scaled("-0.001")), "");  // a mirrored axis is allowed
  for (const char* bad : {"0", "0.0", "nan", "NaN", "inf", "-inf"}) {
    const std::string message = error_of(scaled(bad));
    EXPECT_NE(message.find("scale must be finite and non-zero"), std::string::npos) << bad;
    EXPECT_NE(message.find("/x"), std::string::npos) << message;
  }
  EXPECT_NE(error_of(scaled("0.001", "nan")).find("offset must be finite"), std::string::npos);
}

std::string pinhole(const std::string& width, const std::string& focal = "0.01") {
  return R"(<?xml version="1.0"?><e57Root type="Structure" xmlns="http://www.astm.org/COMMIT/E57/2010-e57-v1.0">
    <image type="Structure"><pinholeRepresentation type="Structure">
      <jpegImage type="Blob" fileOffset="100" length="10"/>
      <imageWidth type="Integer">)" +
         width + R"(</imageWidth><imageHeight type="Integer">480</imageHeight>
      <pixelWidth type="Float">1e-5</pixelWidth><pixelHeight type="Float">1e-5</pixelHeight>
      <focalLength type="Float">)" +
         focal + R"(</focalLength>
    </pinholeRepresentation></image></e57Root>)";
}

std::string image_error(const std::string& xml) {
  const Element root = parse_xml(xml, "mem.e57");
  try {
    image2d_from_element(*root.find("image"));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(E57ImpossibleValues, ImageSizesMustBePositive) {
  EXPECT_EQ(image_error(pinhole("640")), "");
  for (const char* bad : {"-640", "0", "2000000"}) {
    const std::string message = image_error(pinhole(bad));
    EXPECT_NE(message.find("image width"), std::string::npos) << bad << ": " << message;
    EXPECT_NE(message.find("imageWidth"), std::string::npos) << message;
  }
  EXPECT_NE(image_error(pinhole("640", "-0.01")).find("focalLength"), std::string::npos);
}

}  // namespace
}  // namespace coloc::e57
