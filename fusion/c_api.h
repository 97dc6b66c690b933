/* coloc fusion: C ABI for engine plugins (Unity native plugins, Unreal modules, anything that
 * can call C). Shared library: libcoloc_fusion_c.so. Usable from C99 and C++.
 *
 * What it does: the headset reports xr_from_head poses (its own drifting frame) at its frame
 * rate; the localizer reports world_from_head poses (the laser scan's frame) at 15-60 Hz, stamped
 * at the camera's exposure time, either pushed through this API or received over OSC
 * (/coloc/pose, see the README's "OSC address space"). Every headset pose comes back as a fused
 * world_from_head pose: D * xr_from_head, with D the Kalman-filtered drift (Michiels et al. 2024
 * section 5.2, plus time alignment, gating and an optional rate limit).
 *
 * Conventions: times in seconds on one clock shared by headset and localizer; positions in
 * metres; quaternions as x, y, z, w (Hamilton, unit norm; active rotation of the pose's frame).
 * Poses are "a_from_b": they map points of frame b into frame a. The engine converts its own
 * handedness/axes before calling (Unity is left-handed, y up).
 *
 * Threading: all functions on one handle are thread-safe (an internal lock); the OSC receiver
 * runs on its own thread between coloc_fusion_start_osc and coloc_fusion_stop_osc. No function
 * blocks longer than the time it takes to join that thread. Nothing throws or aborts: errors
 * are status codes, with a message from coloc_fusion_last_error.
 *
 * Ownership: coloc_fusion_create returns a handle the caller releases with
 * coloc_fusion_destroy; every pointer argument is borrowed for the duration of the call only. */
#ifndef COLOC_FUSION_C_API_H
#define COLOC_FUSION_C_API_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define COLOC_FUSION_API __declspec(dllexport)
#else
#define COLOC_FUSION_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped whenever a struct below changes layout. */
#define COLOC_FUSION_ABI_VERSION 1

typedef struct coloc_fusion coloc_fusion; /* opaque handle */

typedef enum coloc_status {
  COLOC_OK = 0,
  COLOC_ERROR_INVALID_ARGUMENT = 1, /* NULL pointer, non-finite number, bad option */
  COLOC_ERROR_NETWORK = 2,          /* socket could not be bound or a URL not resolved */
  COLOC_ERROR_INTERNAL = 3
} coloc_status;

/* Tracking state of a global pose (as on the wire). */
/* ODOMETRY: the localizer carries its pose on by visual odometry outside its map; ignored (it
 * drifts like the headset). */
enum {
  COLOC_TRACKING_LOST = 0,
  COLOC_TRACKING_OK = 1,
  COLOC_TRACKING_RELOCALIZED = 2,
  COLOC_TRACKING_ODOMETRY = 3
};
/* State of the fused output. */
enum {
  COLOC_FUSION_WAITING = 0, /* no global pose yet: fused = raw headset pose */
  COLOC_FUSION_TRACKING = 1,
  COLOC_FUSION_HOLDING = 2 /* global poses stopped: the last drift is held */
};

typedef struct coloc_pose {
  double time;           /* s */
  double position[3];    /* m */
  double orientation[4]; /* x, y, z, w */
} coloc_pose;

typedef struct coloc_fusion_options {
  uint32_t abi_version; /* set by coloc_fusion_default_options; must equal the ABI version */
  /* Drift filter (defaults: the paper's values). */
  double process_noise;        /* 0.001 */
  double measurement_noise;    /* 0.9 */
  double translation_sigma;    /* m, noise of one global pose, for the gate: 0.03 */
  double rotation_sigma;       /* quaternion units (~half angle, rad): 0.01 */
  int gating;                  /* 1: reject improbable global poses (Mahalanobis) */
  double gate_chi2;            /* 16.27 (99.9 % of chi^2 with 3 dof) */
  int time_alignment;          /* 1: compare a global pose with the headset at its exposure time */
  double hold_after;           /* s without global poses before the state says HOLDING: 0.5 */
  double max_correction_speed; /* m/s at the head, 0 = no limit */
  double max_correction_rate;  /* rad/s, 0 = no limit */
  /* OSC (UDP). The socket is bound at creation, so its port is known before starting. */
  const char* bind_address; /* "127.0.0.1" (NULL = loopback); "0.0.0.0" for all interfaces */
  int port;                 /* 0 = any free port */
  const char* publish_url;  /* "osc.udp://host:port" for /coloc/fused_pose, or NULL */
} coloc_fusion_options;

typedef struct coloc_fusion_stats {
  uint64_t xr_poses, global_poses, accepted, initialized, rejected, lost, unaligned, out_of_order;
  uint64_t osc_packets, osc_messages, osc_malformed, osc_oversized, osc_wrong_types,
      osc_unknown_address, osc_invalid_values, osc_out_of_order, osc_published;
  int state; /* COLOC_FUSION_* */
} coloc_fusion_stats;

COLOC_FUSION_API int coloc_fusion_abi_version(void);
COLOC_FUSION_API void coloc_fusion_default_options(coloc_fusion_options* options);

/* Returns NULL on failure and writes the reason into error (if error_size > 0). */
COLOC_FUSION_API coloc_fusion* coloc_fusion_create(const coloc_fusion_options* options, char* error,
                                                   size_t error_size);
COLOC_FUSION_API void coloc_fusion_destroy(coloc_fusion* fusion); /* NULL is allowed */

/* A global pose world_from_head stamped at its exposure time; tracking: COLOC_TRACKING_*. */
COLOC_FUSION_API coloc_status coloc_fusion_push_global_pose(coloc_fusion* fusion,
                                                            const coloc_pose* world_from_head,
                                                            int tracking);
/* A headset pose xr_from_head; writes the fused world_from_head (fused may be NULL). */
COLOC_FUSION_API coloc_status coloc_fusion_push_xr_pose(coloc_fusion* fusion,
                                                        const coloc_pose* xr_from_head,
                                                        coloc_pose* fused, int* state);
/* The latest fused pose (state may be NULL). */
COLOC_FUSION_API coloc_status coloc_fusion_get_fused_pose(coloc_fusion* fusion, coloc_pose* fused,
                                                          int* state);

COLOC_FUSION_API coloc_status coloc_fusion_start_osc(coloc_fusion* fusion);
COLOC_FUSION_API coloc_status coloc_fusion_stop_osc(coloc_fusion* fusion);
COLOC_FUSION_API int coloc_fusion_osc_port(const coloc_fusion* fusion); /* -1 for NULL */

COLOC_FUSION_API coloc_status coloc_fusion_get_stats(const coloc_fusion* fusion,
                                                     coloc_fusion_stats* stats);
/* The message of the last failed call on this handle ("" if none); valid until the next call. */
COLOC_FUSION_API const char* coloc_fusion_last_error(const coloc_fusion* fusion);

/* For bindings in other languages (C# P/Invoke, Python ctypes) that mirror the structs above:
 * sizeof of each, so a binding compares them with its own copies when it loads and a layout
 * drift is an error at load instead of garbage at run time. 0 for an unknown id. */
enum {
  COLOC_FUSION_STRUCT_POSE = 0,    /* coloc_pose */
  COLOC_FUSION_STRUCT_OPTIONS = 1, /* coloc_fusion_options */
  COLOC_FUSION_STRUCT_STATS = 2    /* coloc_fusion_stats */
};
COLOC_FUSION_API size_t coloc_fusion_struct_size(int which);
/* The name of a status code ("COLOC_ERROR_NETWORK"), or "unknown status"; static storage. Lets
 * a binding's exception say which code it was without copying the enum's spelling. */
COLOC_FUSION_API const char* coloc_fusion_status_name(int status);

#ifdef __cplusplus
}
#endif

#endif /* COLOC_FUSION_C_API_H */
