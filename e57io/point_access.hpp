#pragma once
// Internal: maps a PointField to its vector in a PointBuffer, and to the decoder's sink type.

#include "e57io/compressed_vector.hpp"
#include "e57io/types.hpp"

namespace coloc::e57 {

// Calls f(vector) with the vector of `field` (const if `b` is const).
template <typename B, typename F>
void with_vector(B& b, PointField field, F&& f) {
  switch (field) {
    case PointField::kCartesianX:
      f(b.cartesian_x);
      break;
    case PointField::kCartesianY:
      f(b.cartesian_y);
      break;
    case PointField::kCartesianZ:
      f(b.cartesian_z);
      break;
    case PointField::kCartesianInvalidState:
      f(b.cartesian_invalid_state);
      break;
    case PointField::kSphericalRange:
      f(b.spherical_range);
      break;
    case PointField::kSphericalAzimuth:
      f(b.spherical_azimuth);
      break;
    case PointField::kSphericalElevation:
      f(b.spherical_elevation);
      break;
    case PointField::kSphericalInvalidState:
      f(b.spherical_invalid_state);
      break;
    case PointField::kIntensity:
      f(b.intensity);
      break;
    case PointField::kIsIntensityInvalid:
      f(b.is_intensity_invalid);
      break;
    case PointField::kColorRed:
      f(b.color_red);
      break;
    case PointField::kColorGreen:
      f(b.color_green);
      break;
    case PointField::kColorBlue:
      f(b.color_blue);
      break;
    case PointField::kIsColorInvalid:
      f(b.is_color_invalid);
      break;
    case PointField::kRowIndex:
      f(b.row_index);
      break;
    case PointField::kColumnIndex:
      f(b.column_index);
      break;
    case PointField::kReturnIndex:
      f(b.return_index);
      break;
    case PointField::kReturnCount:
      f(b.return_count);
      break;
    case PointField::kTimeStamp:
      f(b.time_stamp);
      break;
    case PointField::kIsTimeStampInvalid:
      f(b.is_time_stamp_invalid);
      break;
  }
}

template <typename T>
constexpr Sink::Type sink_type() {
  if constexpr (std::is_same_v<T, double>) return Sink::Type::kDouble;
  if constexpr (std::is_same_v<T, float>) return Sink::Type::kFloat;
  if constexpr (std::is_same_v<T, std::int8_t>) return Sink::Type::kInt8;
  if constexpr (std::is_same_v<T, std::int32_t>) return Sink::Type::kInt32;
  return Sink::Type::kInt64;
}

// The sink writing `field` into b (vector already sized), starting at point `offset`.
inline Sink sink_for(PointBuffer& b, PointField field, std::size_t offset = 0) {
  Sink s;
  with_vector(b, field, [&](auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    s.type = sink_type<T>();
    s.data = v.data() + offset;
  });
  return s;
}

}  // namespace coloc::e57
