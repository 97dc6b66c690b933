/* A small C program using the coloc fusion C library the way an engine plugin would: create a
 * fuser, feed it headset poses at 90 Hz and global poses at 20 Hz, read fused poses and
 * statistics. Self-checking (exit code 0 when the fused pose matches the truth), so CI runs it.
 *
 * The scene: the headset's frame is off by 1 m in x and 10 degrees of yaw from the scan's
 * frame; the user walks along y at 1 m/s. */
#include <math.h>
#include <stdio.h>

#include "fusion/c_api.h"

static void yaw_pose(coloc_pose* p, double t, double yaw, double x, double y, double z) {
  p->time = t;
  p->position[0] = x;
  p->position[1] = y;
  p->position[2] = z;
  p->orientation[0] = 0.0;
  p->orientation[1] = 0.0;
  p->orientation[2] = sin(0.5 * yaw);
  p->orientation[3] = cos(0.5 * yaw);
}

int main(void) {
  const double drift_yaw = 10.0 * 3.14159265358979 / 180.0;
  const double c = cos(drift_yaw), s = sin(drift_yaw);
  coloc_fusion_options options;
  char error[256];
  coloc_fusion* fusion;
  coloc_pose xr, global, fused;
  coloc_fusion_stats stats;
  int state = -1, i;
  double dx, dy;

  coloc_fusion_default_options(&options);
  fusion = coloc_fusion_create(&options, error, sizeof(error));
  if (fusion == NULL) {
    fprintf(stderr, "coloc_fusion_create: %s\n", error);
    return 1;
  }
  for (i = 0; i < 90 * 20; ++i) {
    const double t = i / 90.0;
    /* Headset: xr_from_head. Truth: world_from_head = D * xr_from_head, D = (yaw, +1 m x). */
    yaw_pose(&xr, t, 0.3, 0.0, t, 1.7);
    if (coloc_fusion_push_xr_pose(fusion, &xr, &fused, &state) != COLOC_OK) {
      fprintf(stderr, "push_xr_pose: %s\n", coloc_fusion_last_error(fusion));
      return 1;
    }
    if (i % 9 == 0 || i % 9 == 5) { /* ~20 Hz global poses, stamped at the exposure time */
      yaw_pose(&global, t, 0.3 + drift_yaw, 1.0 - s * t, c * t, 1.7);
      if (coloc_fusion_push_global_pose(fusion, &global, COLOC_TRACKING_OK) != COLOC_OK) {
        fprintf(stderr, "push_global_pose: %s\n", coloc_fusion_last_error(fusion));
        return 1;
      }
    }
  }
  coloc_fusion_get_stats(fusion, &stats);
  dx = fused.position[0] - (1.0 - s * fused.time);
  dy = fused.position[1] - c * fused.time;
  printf("fused t=%.3f s: position %.4f %.4f %.4f m, state %d, error %.2e m\n", fused.time,
         fused.position[0], fused.position[1], fused.position[2], state, sqrt(dx * dx + dy * dy));
  printf("stats: %llu headset poses, %llu global poses, %llu accepted, %llu rejected\n",
         (unsigned long long)stats.xr_poses, (unsigned long long)stats.global_poses,
         (unsigned long long)stats.accepted, (unsigned long long)stats.rejected);
  coloc_fusion_destroy(fusion);
  return (state == COLOC_FUSION_TRACKING && sqrt(dx * dx + dy * dy) < 1e-3) ? 0 : 1;
}
