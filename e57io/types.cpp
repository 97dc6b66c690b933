#include "e57io/types.hpp"

#include <cmath>
#include <cstring>
#include <type_traits>

#include "e57io/point_access.hpp"

namespace coloc::e57 {
namespace {

constexpr const char* kFieldNames[kPointFieldCount] = {
    "cartesianX",     "cartesianY",         "cartesianZ",         "cartesianInvalidState",
    "sphericalRange", "sphericalAzimuth",   "sphericalElevation", "sphericalInvalidState",
    "intensity",      "isIntensityInvalid", "colorRed",           "colorGreen",
    "colorBlue",      "isColorInvalid",     "rowIndex",           "columnIndex",
    "returnIndex",    "returnCount",        "timeStamp",          "isTimeStampInvalid"};

}  // namespace

const char* field_name(PointField field) {
  return kFieldNames[static_cast<std::size_t>(field)];
}

std::optional<PointField> field_from_name(const std::string& name) {
  for (std::size_t i = 0; i < kPointFieldCount; ++i) {
    if (name == kFieldNames[i]) return static_cast<PointField>(i);
  }
  return std::nullopt;
}

FieldSpec FieldSpec::integer(PointField f, std::int64_t min, std::int64_t max) {
  return FieldSpec{.field = f, .kind = FieldKind::kInteger, .minimum = min, .maximum = max};
}

FieldSpec FieldSpec::scaled(PointField f, double scale, double min_value, double max_value,
                            double offset) {
  return FieldSpec{.field = f,
                   .kind = FieldKind::kScaledInteger,
                   .minimum = static_cast<std::int64_t>(std::floor((min_value - offset) / scale)),
                   .maximum = static_cast<std::int64_t>(std::ceil((max_value - offset) / scale)),
                   .scale = scale,
                   .offset = offset};
}

FieldSpec FieldSpec::float64(PointField f) {
  return FieldSpec{.field = f, .kind = FieldKind::kFloat, .single_precision = false};
}

FieldSpec FieldSpec::float32(PointField f) {
  return FieldSpec{.field = f, .kind = FieldKind::kFloat, .single_precision = true};
}

void PointBuffer::reset(std::uint32_t mask, std::size_t n) {
  present_mask = mask;
  size = n;
  for (std::size_t i = 0; i < kPointFieldCount; ++i) {
    const auto f = static_cast<PointField>(i);
    with_vector(*this, f, [&](auto& v) {
      if (present(f)) {
        v.resize(n);
      } else {
        v.clear();
      }
    });
  }
}

void PointBuffer::append(const PointBuffer& other, std::size_t i) {
  for (std::size_t k = 0; k < kPointFieldCount; ++k) {
    const auto f = static_cast<PointField>(k);
    if (!present(f)) continue;
    with_vector(other, f, [&](const auto& sv) {
      with_vector(*this, f, [&](auto& dv) {
        using S = std::decay_t<decltype(sv)>;
        using D = std::decay_t<decltype(dv)>;
        if constexpr (std::is_same_v<S, D>) dv.push_back(sv[i]);
      });
    });
  }
  ++size;
}

}  // namespace coloc::e57
