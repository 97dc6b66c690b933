// The C ABI (c_api.h) over FusionNode. No exception crosses this boundary.

#include "fusion/c_api.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <string>

#include "fusion/osc_node.hpp"
#include "slam/core/error.hpp"
#include "slam/core/rigid.hpp"

struct coloc_fusion {
  std::unique_ptr<coloc::fusion::FusionNode> node;
  mutable std::mutex error_mutex;  // guards last_error only
  mutable std::string last_error;
};

namespace {

using coloc::fusion::FusedPose;
using coloc::fusion::FusionNode;

void copy_message(const std::string& message, char* out, size_t size) {
  if (out == nullptr || size == 0) return;
  const size_t n = std::min(size - 1, message.size());
  std::memcpy(out, message.data(), n);
  out[n] = '\0';
}

coloc_status fail(const coloc_fusion* f, coloc_status status, const std::string& message) {
  if (f != nullptr) {
    const std::lock_guard lock(f->error_mutex);
    f->last_error = message;
  }
  return status;
}

bool read_pose(const coloc_pose* in, double& time, coloc::SE3& pose) {
  if (in == nullptr || !std::isfinite(in->time)) return false;
  Eigen::Vector3d p(in->position[0], in->position[1], in->position[2]);
  Eigen::Vector4d q(in->orientation[0], in->orientation[1], in->orientation[2], in->orientation[3]);
  if (!p.allFinite() || !q.allFinite() || q.norm() < 0.5) return false;
  q.normalize();
  time = in->time;
  pose = coloc::SE3(Eigen::Quaterniond(q[3], q[0], q[1], q[2]), p);
  return true;
}

void write_pose(const FusedPose& given, coloc_pose* out, int* state) {
  // No non-finite number leaves the ABI: such a pose goes out as the identity in state 0, as
  // the OSC encoder sends it (fusion/osc.hpp lost_message).
  FusedPose f = given;
  if (!std::isfinite(f.time) || !coloc::finite_pose(f.world_from_head)) {
    f.time = std::isfinite(f.time) ? f.time : 0.0;
    f.world_from_head = coloc::SE3();
    f.state = static_cast<decltype(f.state)>(0);
  }
  if (out != nullptr) {
    out->time = f.time;
    const Eigen::Vector3d& p = f.world_from_head.translation();
    const Eigen::Quaterniond& q = f.world_from_head.quaternion();
    out->position[0] = p.x();
    out->position[1] = p.y();
    out->position[2] = p.z();
    out->orientation[0] = q.x();
    out->orientation[1] = q.y();
    out->orientation[2] = q.z();
    out->orientation[3] = q.w();
  }
  if (state != nullptr) *state = static_cast<int>(f.state);
}

coloc::fusion::FusionNodeOptions to_options(const coloc_fusion_options& o) {
  coloc::fusion::FusionNodeOptions n;
  auto& filter = n.fuser.filter;
  filter.process_noise = o.process_noise;
  filter.measurement_noise = o.measurement_noise;
  filter.translation_sigma = o.translation_sigma;
  filter.rotation_sigma = o.rotation_sigma;
  filter.gating = o.gating != 0;
  filter.gate_chi2 = o.gate_chi2;
  n.fuser.time_alignment = o.time_alignment != 0;
  n.fuser.hold_after = o.hold_after;
  n.fuser.max_correction_speed = o.max_correction_speed;
  n.fuser.max_correction_rate = o.max_correction_rate;
  n.endpoint.bind_address = o.bind_address != nullptr ? o.bind_address : "127.0.0.1";
  n.endpoint.port = o.port;
  if (o.publish_url != nullptr && o.publish_url[0] != '\0') n.publish.emplace_back(o.publish_url);
  return n;
}

}  // namespace

extern "C" {

int coloc_fusion_abi_version(void) {
  return COLOC_FUSION_ABI_VERSION;
}

void coloc_fusion_default_options(coloc_fusion_options* options) {
  if (options == nullptr) return;
  const coloc::fusion::FuserOptions d;
  *options = coloc_fusion_options{};
  options->abi_version = COLOC_FUSION_ABI_VERSION;
  options->process_noise = d.filter.process_noise;
  options->measurement_noise = d.filter.measurement_noise;
  options->translation_sigma = d.filter.translation_sigma;
  options->rotation_sigma = d.filter.rotation_sigma;
  options->gating = d.filter.gating ? 1 : 0;
  options->gate_chi2 = d.filter.gate_chi2;
  options->time_alignment = d.time_alignment ? 1 : 0;
  options->hold_after = d.hold_after;
  options->max_correction_speed = d.max_correction_speed;
  options->max_correction_rate = d.max_correction_rate;
  options->bind_address = "127.0.0.1";
  options->port = 0;
  options->publish_url = nullptr;
}

coloc_fusion* coloc_fusion_create(const coloc_fusion_options* options, char* error,
                                  size_t error_size) {
  try {
    coloc_fusion_options o;
    coloc_fusion_default_options(&o);
    if (options != nullptr) {
      if (options->abi_version != COLOC_FUSION_ABI_VERSION) {
        copy_message(
            "coloc_fusion_options.abi_version mismatch: call "
            "coloc_fusion_default_options first",
            error, error_size);
        return nullptr;
      }
      o = *options;
    }
    auto handle = std::make_unique<coloc_fusion>();
    handle->node = std::make_unique<FusionNode>(to_options(o));
    copy_message("", error, error_size);
    return handle.release();
  } catch (const coloc::Error& e) {
    copy_message(coloc::format_error(e.message(), e.context()), error, error_size);
  } catch (const std::exception& e) {
    copy_message(e.what(), error, error_size);
  }
  return nullptr;
}

void coloc_fusion_destroy(coloc_fusion* fusion) {
  delete fusion;
}

coloc_status coloc_fusion_push_global_pose(coloc_fusion* fusion, const coloc_pose* world_from_head,
                                           int tracking) {
  if (fusion == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  double time = 0.0;
  coloc::SE3 pose;
  if (!read_pose(world_from_head, time, pose)) {
    return fail(fusion, COLOC_ERROR_INVALID_ARGUMENT, "global pose is NULL or not finite");
  }
  if (tracking < 0 || tracking > 3) {
    return fail(fusion, COLOC_ERROR_INVALID_ARGUMENT, "tracking must be 0, 1, 2 or 3");
  }
  try {
    fusion->node->push_global_pose(time, pose, coloc::fusion::tracking_state_from_wire(tracking));
    return COLOC_OK;
  } catch (const std::exception& e) {
    return fail(fusion, COLOC_ERROR_INTERNAL, e.what());
  }
}

coloc_status coloc_fusion_push_xr_pose(coloc_fusion* fusion, const coloc_pose* xr_from_head,
                                       coloc_pose* fused, int* state) {
  if (fusion == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  double time = 0.0;
  coloc::SE3 pose;
  if (!read_pose(xr_from_head, time, pose)) {
    return fail(fusion, COLOC_ERROR_INVALID_ARGUMENT, "headset pose is NULL or not finite");
  }
  try {
    write_pose(fusion->node->push_xr_pose(time, pose), fused, state);
    return COLOC_OK;
  } catch (const std::exception& e) {
    return fail(fusion, COLOC_ERROR_INTERNAL, e.what());
  }
}

coloc_status coloc_fusion_get_fused_pose(coloc_fusion* fusion, coloc_pose* fused, int* state) {
  if (fusion == nullptr || fused == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  write_pose(fusion->node->latest(), fused, state);
  return COLOC_OK;
}

coloc_status coloc_fusion_start_osc(coloc_fusion* fusion) {
  if (fusion == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  try {
    fusion->node->start();
    return COLOC_OK;
  } catch (const std::exception& e) {
    return fail(fusion, COLOC_ERROR_NETWORK, e.what());
  }
}

coloc_status coloc_fusion_stop_osc(coloc_fusion* fusion) {
  if (fusion == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  fusion->node->stop();
  return COLOC_OK;
}

int coloc_fusion_osc_port(const coloc_fusion* fusion) {
  return fusion == nullptr ? -1 : fusion->node->port();
}

coloc_status coloc_fusion_get_stats(const coloc_fusion* fusion, coloc_fusion_stats* stats) {
  if (fusion == nullptr || stats == nullptr) return COLOC_ERROR_INVALID_ARGUMENT;
  const coloc::fusion::FusionNodeStats s = fusion->node->stats();
  *stats = coloc_fusion_stats{};
  stats->xr_poses = s.fuser.xr_poses;
  stats->global_poses = s.fuser.global_poses;
  stats->accepted = s.fuser.accepted;
  stats->initialized = s.fuser.initialized;
  stats->rejected = s.fuser.rejected;
  stats->lost = s.fuser.lost;
  stats->unaligned = s.fuser.unaligned;
  stats->out_of_order = s.fuser.out_of_order;
  stats->osc_packets = s.osc.packets;
  stats->osc_messages = s.osc.messages;
  stats->osc_malformed = s.osc.malformed;
  stats->osc_oversized = s.osc.oversized;
  stats->osc_wrong_types = s.osc.wrong_types;
  stats->osc_unknown_address = s.osc.unknown_address;
  stats->osc_invalid_values = s.osc.invalid_values;
  stats->osc_out_of_order = s.out_of_order;
  stats->osc_published = s.published;
  stats->state = static_cast<int>(fusion->node->latest().state);
  return COLOC_OK;
}

const char* coloc_fusion_last_error(const coloc_fusion* fusion) {
  if (fusion == nullptr) return "NULL handle";
  const std::lock_guard lock(fusion->error_mutex);
  return fusion->last_error.c_str();
}

size_t coloc_fusion_struct_size(int which) {
  switch (which) {
    case COLOC_FUSION_STRUCT_POSE:
      return sizeof(coloc_pose);
    case COLOC_FUSION_STRUCT_OPTIONS:
      return sizeof(coloc_fusion_options);
    case COLOC_FUSION_STRUCT_STATS:
      return sizeof(coloc_fusion_stats);
    default:
      return 0;
  }
}

const char* coloc_fusion_status_name(int status) {
  switch (status) {
    case COLOC_OK:
      return "COLOC_OK";
    case COLOC_ERROR_INVALID_ARGUMENT:
      return "COLOC_ERROR_INVALID_ARGUMENT";
    case COLOC_ERROR_NETWORK:
      return "COLOC_ERROR_NETWORK";
    case COLOC_ERROR_INTERNAL:
      return "COLOC_ERROR_INTERNAL";
    default:
      return "unknown status";
  }
}

}  // extern "C"
