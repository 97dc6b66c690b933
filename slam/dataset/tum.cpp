// TUM RGB-D layout: rgb.txt and depth.txt ("timestamp path" per line), optionally
// associations.txt ("t_rgb rgb_path t_depth depth_path"), groundtruth.txt in TUM trajectory
// format, depth PNGs of 16 bit with 5000 units per metre. coloc's recorder and twin add
// imu.txt ("t gx gy gz ax ay az": rad/s and m/s^2 in the IMU frame), read when present.

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/dataset/text_table.hpp"

namespace coloc::dataset {
namespace {

struct Entry {
  double t_color = 0.0;
  std::filesystem::path color;
  double t_depth = 0.0;
  std::filesystem::path depth;
};

// A frame listed twice (a list concatenated with itself) would be mapped twice, and the
// trajectory would have two poses at one timestamp that `coloc eval` refuses: a repeated
// timestamp is refused, naming both lines. `rows` holds (time, line), sorted by time.
void refuse_repeats(const std::filesystem::path& file,
                    const std::vector<std::pair<double, std::int64_t>>& rows) {
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (rows[i].first != rows[i - 1].first) continue;
    const auto [first, second] = std::minmax(rows[i - 1].second, rows[i].second);
    throw Error("timestamp " + std::to_string(rows[i].first) + " is listed twice (lines " +
                    std::to_string(first) + " and " + std::to_string(second) +
                    "): each frame must be listed once",
                {.file = file.string(), .line = second});
  }
}

// A "timestamp path" list as timestamps (a Trajectory with identity poses, so the shared
// association code applies) and paths, both sorted by time.
Trajectory list_as_trajectory(const std::filesystem::path& file, std::vector<std::string>* paths) {
  struct Row {
    double time;
    std::string path;
    std::int64_t line;
  };
  std::vector<Row> rows;
  for (const auto& row : read_text_table(file)) {
    if (row.fields.size() < 2) {
      throw Error("expected 'timestamp path'", {.file = file.string(), .line = row.line});
    }
    rows.push_back({parse_double(file, row, 0), row.fields[1], row.line});
  }
  std::stable_sort(rows.begin(), rows.end(),
                   [](const Row& a, const Row& b) { return a.time < b.time; });
  std::vector<std::pair<double, std::int64_t>> times;
  for (const Row& r : rows)
    times.emplace_back(r.time, r.line);
  refuse_repeats(file, times);
  Trajectory t;
  for (Row& r : rows) {
    t.push_back({r.time, SE3()});
    paths->push_back(std::move(r.path));
  }
  return t;
}

class TumSequence final : public Sequence {
 public:
  TumSequence(const std::filesystem::path& dir, const SequenceOptions& options)
      : Sequence(dir), dir_(dir), scale_(options.depth_scale > 0.0 ? options.depth_scale : 5000.0) {
    if (!options.associations.empty()) {
      check_input_file(options.associations, "associations file");
      read_associations(options.associations);
    } else if (std::filesystem::exists(dir / "associations.txt")) {
      read_associations(dir / "associations.txt");
    } else {
      associate(options.max_association_dt);
    }
    if (entries_.empty()) throw Error("sequence has no frames", {.file = dir.string()});
    if (std::filesystem::exists(dir / "groundtruth.txt")) {
      ground_truth_ = read_tum_trajectory(dir / "groundtruth.txt");
    }
    if (std::filesystem::exists(dir / "imu.txt")) read_imu(dir / "imu.txt");
  }

  std::string format() const override { return "tum"; }
  std::size_t size() const override { return entries_.size(); }
  double timestamp(std::size_t i) const override { return entries_.at(i).t_color; }
  const Trajectory& ground_truth() const override { return ground_truth_; }
  const std::vector<ImuSample>& imu() const override { return imu_; }
  std::optional<Camera> camera() const override { return std::nullopt; }

  Frame frame(std::size_t i) const override {
    const Entry& e = entries_.at(i);
    Frame f;
    f.index = i;
    f.timestamp = e.t_color;
    f.color_path = dir_ / e.color;
    f.depth_path = dir_ / e.depth;
    f.color = read_image(f.color_path);
    f.depth = read_depth(f.depth_path, scale_);
    return f;
  }

 private:
  void read_associations(const std::filesystem::path& file) {
    std::vector<std::pair<double, std::int64_t>> times;
    for (const auto& row : read_text_table(file)) {
      if (row.fields.size() < 4) {
        throw Error("expected 't_rgb rgb t_depth depth'",
                    {.file = file.string(), .line = row.line});
      }
      entries_.push_back(
          {parse_double(file, row, 0), row.fields[1], parse_double(file, row, 2), row.fields[3]});
      times.emplace_back(entries_.back().t_color, row.line);
    }
    std::stable_sort(times.begin(), times.end());
    refuse_repeats(file, times);
  }

  void read_imu(const std::filesystem::path& file) {
    for (const auto& row : read_text_table(file)) {
      ImuSample sample;
      sample.timestamp = parse_double(file, row, 0);
      for (int k = 0; k < 3; ++k) {
        sample.gyro(k) = parse_double(file, row, 1 + k);
        sample.accel(k) = parse_double(file, row, 4 + k);
      }
      imu_.push_back(sample);
    }
    std::stable_sort(imu_.begin(), imu_.end(),
                     [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  }

  // Order-preserving nearest-timestamp pairing of rgb.txt and depth.txt (see
  // associate_in_order: the greedy pairing of the TUM tools' associate.py drops frames).
  void associate(double max_dt) {
    std::vector<std::string> color_paths;
    std::vector<std::string> depth_paths;
    const Trajectory colors = list_as_trajectory(dir_ / "rgb.txt", &color_paths);
    const Trajectory depths = list_as_trajectory(dir_ / "depth.txt", &depth_paths);
    std::vector<double> tc;
    std::vector<double> td;
    for (const auto& p : colors)
      tc.push_back(p.timestamp);
    for (const auto& p : depths)
      td.push_back(p.timestamp);
    for (const auto& [i, j] : associate_in_order(tc, td, max_dt)) {
      entries_.push_back(
          {colors[i].timestamp, color_paths[i], depths[j].timestamp, depth_paths[j]});
    }
  }

  std::filesystem::path dir_;
  double scale_;
  std::vector<Entry> entries_;
  Trajectory ground_truth_;
  std::vector<ImuSample> imu_;
};

}  // namespace

std::unique_ptr<Sequence> open_tum(const std::filesystem::path& dir,
                                   const SequenceOptions& options) {
  return std::make_unique<TumSequence>(dir, options);
}

}  // namespace coloc::dataset
