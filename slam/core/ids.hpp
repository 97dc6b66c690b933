#pragma once
// Strong id types: an id of one kind cannot be passed where another is expected. Ids are issued
// by their owner (the Map issues keyframe and point ids); there are no static counters.

#include <cstdint>
#include <functional>
#include <limits>
#include <ostream>

namespace coloc {

template <typename Tag, typename Value = std::uint64_t>
class Id {
 public:
  using ValueType = Value;
  static constexpr Value kInvalidValue = std::numeric_limits<Value>::max();

  constexpr Id() = default;
  constexpr explicit Id(Value value) : value_(value) {}

  constexpr Value value() const { return value_; }
  constexpr bool valid() const { return value_ != kInvalidValue; }
  static constexpr Id invalid() { return Id(); }

  // NOLINTNEXTLINE(modernize-use-nullptr): clang-tidy 14 misreads the defaulted comparison
  constexpr auto operator<=>(const Id&) const = default;

  friend std::ostream& operator<<(std::ostream& os, const Id& id) { return os << id.value_; }

 private:
  Value value_ = kInvalidValue;
};

// Issues consecutive ids; owned by whoever owns the id space (never global).
template <typename IdType>
class IdIssuer {
 public:
  IdType next() { return IdType(next_++); }
  // The value next() will issue; saved with a map so that a restored map never reissues the id
  // of something erased before the save (frames and erased keyframes may still refer to it).
  typename IdType::ValueType peek() const { return next_; }
  // After loading a saved map: continue after the largest id seen.
  void continue_after(IdType id) {
    if (id.valid() && id.value() >= next_) next_ = id.value() + 1;
  }

 private:
  typename IdType::ValueType next_ = 0;
};

using FrameId = Id<struct FrameTag>;
using KeyframeId = Id<struct KeyframeTag>;
using MapPointId = Id<struct MapPointTag>;
using CameraId = Id<struct CameraTag, std::uint32_t>;

}  // namespace coloc

template <typename Tag, typename Value>
struct std::hash<coloc::Id<Tag, Value>> {
  std::size_t operator()(const coloc::Id<Tag, Value>& id) const noexcept {
    return std::hash<Value>{}(id.value());
  }
};
