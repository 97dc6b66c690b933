/* coloc localize: C ABI for engine plugins that want the global pose in process (instead of
 * over OSC). Shared library: libcoloc_localize_c.so. Usable from C99 and C++.
 *
 * What it does: loads a saved map (coloc map --save) once and localizes RGB-D frames in it,
 * never changing the map (slam/localize/localizer.hpp). Each frame gives world_from_cam in the
 * map's frame (the scan's frame once the map is registered), its state and quality.
 *
 * Conventions: times in seconds; positions in metres; quaternions x, y, z, w (Hamilton, unit).
 * Poses are "a_from_b": they map points of frame b into frame a.
 *
 * Threading: one handle is used from one thread at a time (frames in order). Several handles
 * may load the same file. Nothing throws or aborts: errors are status codes with a message
 * (coloc_localizer_last_error, or the caller's buffer for coloc_localizer_open).
 *
 * Ownership: coloc_localizer_open returns a handle the caller releases with
 * coloc_localizer_close; pointer arguments are borrowed for the duration of the call only. */
#ifndef COLOC_LOCALIZE_C_API_H
#define COLOC_LOCALIZE_C_API_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define COLOC_LOCALIZE_API __declspec(dllexport)
#else
#define COLOC_LOCALIZE_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped whenever a struct below changes layout. */
#define COLOC_LOCALIZE_ABI_VERSION 1

typedef struct coloc_localizer coloc_localizer; /* opaque handle */

enum {
  COLOC_LOCALIZE_OK = 0,
  COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT = 1, /* NULL pointer, bad size, non-finite time */
  COLOC_LOCALIZE_ERROR_FILE = 2,             /* map, vocabulary or settings unreadable or bad */
  COLOC_LOCALIZE_ERROR_INTERNAL = 3
};

/* State of a pose: the numbers of the OSC /coloc/pose state argument. */
enum {
  COLOC_LOCALIZE_LOST = 0,
  COLOC_LOCALIZE_TRACKING = 1,
  COLOC_LOCALIZE_RELOCALIZED = 2, /* localized again (or for the first time) in this frame */
  COLOC_LOCALIZE_ODOMETRY = 3     /* outside the map: carried on by visual odometry (drifts) */
};

typedef struct coloc_localize_pose {
  double time;                /* the frame's timestamp, seconds */
  int32_t state;              /* COLOC_LOCALIZE_LOST / _TRACKING / _RELOCALIZED / _ODOMETRY */
  int32_t inliers;            /* points supporting the pose (ODOMETRY: the anchor frame's) */
  double position[3];         /* world_from_cam translation, metres (last pose when lost) */
  double orientation[4];      /* world_from_cam rotation, x y z w */
  double reprojection_rms_px; /* quality: inliers' RMS reprojection error (0: lost, ODOMETRY) */
  double ms;                  /* wall time of the call */
} coloc_localize_pose;

COLOC_LOCALIZE_API int coloc_localize_abi_version(void);

/* Loads the map and the vocabulary it was built with. `settings_path` NULL: the camera settings
 * saved in the map. On failure returns NULL and writes a message naming the file (and field)
 * into `error` (NUL-terminated, truncated to error_size; may be NULL). */
COLOC_LOCALIZE_API coloc_localizer* coloc_localizer_open(const char* map_path,
                                                         const char* vocabulary_path,
                                                         const char* settings_path, char* error,
                                                         size_t error_size);
COLOC_LOCALIZE_API void coloc_localizer_close(coloc_localizer* localizer);

/* One frame. `image`: 8-bit, `channels` 1 (grey) or 3 (colour in the settings' Camera.RGB
 * order), rows `image_stride` bytes apart; `depth`: metres as float, 0 = invalid, rows
 * `depth_stride` bytes apart, registered to the image (NULL: no depth). Fills `pose`. */
COLOC_LOCALIZE_API int coloc_localizer_localize(coloc_localizer* localizer, const uint8_t* image,
                                                int width, int height, int channels,
                                                size_t image_stride, const float* depth,
                                                size_t depth_stride, double time,
                                                coloc_localize_pose* pose);

/* Forget the motion: the next frame relocalizes in the whole map. */
COLOC_LOCALIZE_API int coloc_localizer_reset(coloc_localizer* localizer);

/* Anchors every later pose to the scan the map is registered to (coloc localize --scan; see
 * slam/localize/scan_anchor.hpp): `xyz` holds `count` points, x y z interleaved, metres, in the
 * map's frame (a laser scan thinned to about 1 cm is plenty). Each frame's depth is then aligned
 * to the scan's surface and the aligned pose is returned; a frame the alignment refuses keeps
 * its visual pose. `xyz` NULL (count 0) turns it off. Fails with INVALID_ARGUMENT for a
 * non-finite point or a scan without planar surface; the handle is then as before. */
COLOC_LOCALIZE_API int coloc_localizer_anchor_to_scan(coloc_localizer* localizer, const float* xyz,
                                                      size_t count);

/* Keyframes and points of the loaded map; the map's frame name ("slam", "scan", ...). */
COLOC_LOCALIZE_API int coloc_localizer_map_info(const coloc_localizer* localizer,
                                                uint64_t* keyframes, uint64_t* points,
                                                char* frame_name, size_t frame_name_size);

/* The message of the last failed call on this handle ("" if none); valid until the next call. */
COLOC_LOCALIZE_API const char* coloc_localizer_last_error(const coloc_localizer* localizer);

/* sizeof(coloc_localize_pose), for bindings in other languages that mirror the struct: compared
 * with their own copy at load, so a layout drift fails there and not in a frame's output. */
COLOC_LOCALIZE_API size_t coloc_localize_pose_size(void);
/* The name of a status code ("COLOC_LOCALIZE_ERROR_FILE"), or "unknown status"; static. */
COLOC_LOCALIZE_API const char* coloc_localize_status_name(int status);

#ifdef __cplusplus
}
#endif

#endif /* COLOC_LOCALIZE_C_API_H */
