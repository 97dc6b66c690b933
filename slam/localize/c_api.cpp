// The C ABI of the localizer (c_api.h): a handle owning the vocabulary, the loaded map and one
// Localizer; every exception stops here and becomes a status code with a message.
#include "slam/localize/c_api.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/core/rigid.hpp"
#include "slam/localize/localizer.hpp"

struct coloc_localizer {
  coloc::slam::bow::Vocabulary vocabulary;
  std::unique_ptr<coloc::slam::localize::LocalizationMap> map;
  std::unique_ptr<coloc::slam::localize::Localizer> localizer;
  coloc::SE3 last_pose;
  std::string error;
};

namespace {

using coloc::slam::localize::LocalizationResult;
using coloc::slam::localize::LocalizationState;

void copy_text(const std::string& text, char* out, std::size_t size) {
  if (!out || size == 0) return;
  const std::size_t n = std::min(text.size(), size - 1);
  std::memcpy(out, text.data(), n);
  out[n] = '\0';
}

std::string describe(const coloc::Error& e) {
  return coloc::format_error(e.message(), e.context());
}

int fail(coloc_localizer* h, int status, const std::string& message) {
  if (h) h->error = message;
  return status;
}

}  // namespace

extern "C" {

int coloc_localize_abi_version(void) {
  return COLOC_LOCALIZE_ABI_VERSION;
}

coloc_localizer* coloc_localizer_open(const char* map_path, const char* vocabulary_path,
                                      const char* settings_path, char* error,
                                      std::size_t error_size) {
  copy_text("", error, error_size);
  if (!map_path || !vocabulary_path) {
    copy_text("coloc_localizer_open: map_path and vocabulary_path are required", error, error_size);
    return nullptr;
  }
  try {
    auto h = std::make_unique<coloc_localizer>();
    h->vocabulary = coloc::slam::bow::Vocabulary::load(vocabulary_path);
    h->map = coloc::slam::localize::load_localization_map(map_path, h->vocabulary);
    const coloc::settings::Settings settings =
        settings_path ? coloc::settings::load_settings(settings_path)
                      : coloc::slam::localize::settings_saved_in(*h->map, map_path);
    h->localizer = std::make_unique<coloc::slam::localize::Localizer>(
        *h->map, h->vocabulary, settings, coloc::slam::localize::options_from_settings(settings));
    return h.release();
  } catch (const coloc::Error& e) {
    copy_text(describe(e), error, error_size);
  } catch (const std::exception& e) {
    copy_text(std::string("coloc_localizer_open: ") + e.what(), error, error_size);
  } catch (...) {
    copy_text("coloc_localizer_open: unknown error", error, error_size);
  }
  return nullptr;
}

void coloc_localizer_close(coloc_localizer* localizer) {
  delete localizer;
}

int coloc_localizer_localize(coloc_localizer* h, const std::uint8_t* image, int width, int height,
                             int channels, std::size_t image_stride, const float* depth,
                             std::size_t depth_stride, double time, coloc_localize_pose* pose) {
  if (!h) return COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT;
  h->error.clear();
  if (!image || !pose || width <= 0 || height <= 0 || (channels != 1 && channels != 3) ||
      image_stride < static_cast<std::size_t>(width) * static_cast<std::size_t>(channels) ||
      (depth && depth_stride < static_cast<std::size_t>(width) * sizeof(float)) ||
      !std::isfinite(time))
    return fail(h, COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT,
                "coloc_localizer_localize: null pointer, bad size/channels/stride or time");
  try {
    // Views of the caller's memory: the localizer only reads them during the call.
    const cv::Mat img(height, width, channels == 1 ? CV_8UC1 : CV_8UC3,
                      const_cast<std::uint8_t*>(image), image_stride);
    const cv::Mat dep =
        depth ? cv::Mat(height, width, CV_32FC1, const_cast<float*>(depth), depth_stride)
              : cv::Mat();
    const LocalizationResult r = h->localizer->localize(img, dep, time);
    // A pose with a NaN / inf is never handed out: the frame reports lost instead.
    const bool usable = r.state != LocalizationState::kLost && coloc::finite_pose(r.world_from_cam);
    if (usable) h->last_pose = r.world_from_cam;
    pose->time = time;
    pose->state = usable ? static_cast<std::int32_t>(r.state)
                         : static_cast<std::int32_t>(COLOC_LOCALIZE_LOST);
    pose->inliers = r.inliers;
    const Eigen::Vector3d& t = h->last_pose.translation();
    const Eigen::Quaterniond& q = h->last_pose.quaternion();
    pose->position[0] = t.x();
    pose->position[1] = t.y();
    pose->position[2] = t.z();
    pose->orientation[0] = q.x();
    pose->orientation[1] = q.y();
    pose->orientation[2] = q.z();
    pose->orientation[3] = q.w();
    pose->reprojection_rms_px = r.reprojection_rms_px;
    pose->ms = r.total_ms;
    return COLOC_LOCALIZE_OK;
  } catch (const coloc::Error& e) {
    return fail(h, COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT, describe(e));
  } catch (const std::exception& e) {
    return fail(h, COLOC_LOCALIZE_ERROR_INTERNAL, e.what());
  } catch (...) {
    return fail(h, COLOC_LOCALIZE_ERROR_INTERNAL, "unknown error");
  }
}

int coloc_localizer_reset(coloc_localizer* h) {
  if (!h) return COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT;
  try {
    h->localizer->reset();
    return COLOC_LOCALIZE_OK;
  } catch (const std::exception& e) {
    return fail(h, COLOC_LOCALIZE_ERROR_INTERNAL, e.what());
  }
}

int coloc_localizer_anchor_to_scan(coloc_localizer* h, const float* xyz, std::size_t count) {
  if (!h) return COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT;
  h->error.clear();
  if (!xyz || count == 0) {
    if (xyz || count)
      return fail(h, COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT,
                  "coloc_localizer_anchor_to_scan: xyz NULL with a count, or 0 "
                  "points");
    h->localizer->anchor_to_scan(nullptr);
    return COLOC_LOCALIZE_OK;
  }
  try {
    std::vector<Eigen::Vector3f> points(count);
    for (std::size_t i = 0; i < count; ++i) {
      points[i] = Eigen::Vector3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      if (!points[i].allFinite())
        return fail(
            h, COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT,
            "coloc_localizer_anchor_to_scan: point " + std::to_string(i) + " is not finite");
    }
    h->localizer->anchor_to_scan(std::make_shared<const coloc::slam::localize::ScanAnchor>(points));
    return COLOC_LOCALIZE_OK;
  } catch (const coloc::Error& e) {
    return fail(h, COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT, describe(e));
  } catch (const std::exception& e) {
    return fail(h, COLOC_LOCALIZE_ERROR_INTERNAL, e.what());
  }
}

int coloc_localizer_map_info(const coloc_localizer* h, std::uint64_t* keyframes,
                             std::uint64_t* points, char* frame_name, std::size_t frame_name_size) {
  if (!h) return COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT;
  if (keyframes) *keyframes = h->map->keyframes();
  if (points) *points = h->map->points();
  copy_text(h->map->metadata.frame_name, frame_name, frame_name_size);
  return COLOC_LOCALIZE_OK;
}

const char* coloc_localizer_last_error(const coloc_localizer* h) {
  return h ? h->error.c_str() : "null handle";
}

size_t coloc_localize_pose_size(void) {
  return sizeof(coloc_localize_pose);
}

const char* coloc_localize_status_name(int status) {
  switch (status) {
    case COLOC_LOCALIZE_OK:
      return "COLOC_LOCALIZE_OK";
    case COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT:
      return "COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT";
    case COLOC_LOCALIZE_ERROR_FILE:
      return "COLOC_LOCALIZE_ERROR_FILE";
    case COLOC_LOCALIZE_ERROR_INTERNAL:
      return "COLOC_LOCALIZE_ERROR_INTERNAL";
    default:
      return "unknown status";
  }
}

}  // extern "C"
