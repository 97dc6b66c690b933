#pragma once
// A progress bar on stderr for library work that reports (done, total) through a callback, such
// as the map database's saves and loads: the bar is created at the first report, when the total
// is known.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "slam/core/progress.hpp"

namespace coloc {

class RowProgress {
 public:
  RowProgress(std::string label, bool quiet) : label_(std::move(label)), quiet_(quiet) {}
  // The callback to hand to the library; valid while this object lives.
  std::function<void(std::uint64_t, std::uint64_t)> callback() {
    return [this](std::uint64_t done, std::uint64_t total) {
      if (!bar_) bar_.emplace(label_, total, quiet_);
      bar_->set(done);
    };
  }
  void finish() {
    if (bar_) bar_->finish();
  }

 private:
  std::string label_;
  bool quiet_;
  std::optional<Progress> bar_;
};

}  // namespace coloc
