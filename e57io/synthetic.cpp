#include "e57io/synthetic.hpp"

#include <algorithm>

#include "e57io/writer.hpp"

namespace coloc::e57 {

void write_synthetic_scan(const std::filesystem::path& path, std::size_t points, std::size_t chunk,
                          const std::function<void(std::size_t)>& on_progress) {
  using F = PointField;
  Writer w(path);
  w.begin_scan(
      {.name = "synthetic"},
      {FieldSpec::scaled(F::kCartesianX, 1e-4, -100, 100),
       FieldSpec::scaled(F::kCartesianY, 1e-4, -100, 100),
       FieldSpec::scaled(F::kCartesianZ, 1e-4, -100, 100),
       FieldSpec::integer(F::kIntensity, 0, 2047), FieldSpec::integer(F::kColorRed, 0, 255),
       FieldSpec::integer(F::kColorGreen, 0, 255), FieldSpec::integer(F::kColorBlue, 0, 255)});
  const std::uint32_t mask = field_bit(F::kCartesianX) | field_bit(F::kCartesianY) |
                             field_bit(F::kCartesianZ) | field_bit(F::kIntensity) |
                             field_bit(F::kColorRed) | field_bit(F::kColorGreen) |
                             field_bit(F::kColorBlue);
  PointBuffer p;
  chunk = std::max<std::size_t>(chunk, 1);
  for (std::size_t at = 0; at < points;) {
    const std::size_t k = std::min(points - at, chunk);
    p.reset(mask, k);
    for (std::size_t i = 0; i < k; ++i) {
      const std::size_t j = at + i;
      p.cartesian_x[i] = -50.0 + 1e-3 * static_cast<double>(j % 100000);
      p.cartesian_y[i] = -50.0 + 1e-3 * static_cast<double>((j / 100000) % 100000);
      p.cartesian_z[i] = 1e-4 * static_cast<double>(j % 30011);
      p.intensity[i] = static_cast<float>(j % 2048);
      p.color_red[i] = static_cast<float>(j % 256);
      p.color_green[i] = static_cast<float>((j / 3) % 256);
      p.color_blue[i] = static_cast<float>((j / 7) % 256);
    }
    w.add_points(p);
    at += k;
    if (on_progress) on_progress(at);
  }
  w.end_scan();
  w.close();
}

}  // namespace coloc::e57
