#include "slam/dataset/slice.hpp"

#include <algorithm>
#include <limits>

#include "slam/core/error.hpp"

namespace coloc::dataset {
namespace {

class Slice final : public Sequence {
 public:
  Slice(std::unique_ptr<Sequence> whole, std::size_t first, std::size_t last)
      : Sequence(whole->folder()), whole_(std::move(whole)), first_(first), last_(last) {}

  std::string format() const override { return whole_->format(); }
  std::size_t size() const override { return last_ - first_; }
  double timestamp(std::size_t index) const override { return whole_->timestamp(first_ + index); }
  Frame frame(std::size_t index) const override { return whole_->frame(first_ + index); }
  const Trajectory& ground_truth() const override { return whole_->ground_truth(); }
  const std::vector<ImuSample>& imu() const override { return whole_->imu(); }
  std::optional<Camera> camera() const override { return whole_->camera(); }

 private:
  std::unique_ptr<Sequence> whole_;
  std::size_t first_, last_;
};

std::size_t parse_index(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  unsigned long long value = 0;
  try {
    value = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || text[0] == '-')
    throw Error("'" + text + "' is not a frame index", {.field = what});
  return static_cast<std::size_t>(value);
}

}  // namespace

std::unique_ptr<Sequence> slice(std::unique_ptr<Sequence> sequence, std::size_t first,
                                std::size_t last) {
  last = std::min(last, sequence->size());
  if (first >= last)
    throw Error("frames [" + std::to_string(first) + ", " + std::to_string(last) +
                    ") of a sequence of " + std::to_string(sequence->size()) + " frames is empty",
                {.file = sequence->folder().string()});
  return std::make_unique<Slice>(std::move(sequence), first, last);
}

std::pair<std::size_t, std::size_t> parse_frame_range(const std::string& text,
                                                      const std::string& what) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw Error("expected FIRST:LAST (either may be empty), got '" + text + "'", {.field = what});
  const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
  const std::size_t first = a.empty() ? 0 : parse_index(a, what);
  const std::size_t last =
      b.empty() ? std::numeric_limits<std::size_t>::max() : parse_index(b, what);
  return {first, last};
}

}  // namespace coloc::dataset
