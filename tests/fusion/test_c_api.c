/* The fusion C ABI from C: options, argument checks, and OSC end to end on loopback with liblo
 * (C) as the peer. Every wait is bounded. Exit code 0 = pass. */
#include <lo/lo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fusion/c_api.h"

static int failures = 0;
#define CHECK(cond)                                                            \
  do {                                                                         \
    if (!(cond)) {                                                             \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
      ++failures;                                                              \
    }                                                                          \
  } while (0)

static double received_x = 0.0;
static int received_state = -1;
static int received = 0;

static int on_fused(const char* path, const char* types, lo_arg** argv, int argc, lo_message msg,
                    void* user) {
  (void)path;
  (void)msg;
  (void)user;
  if (argc == 10 && strcmp(types, "diifffffff") == 0) {
    /* liblo's arguments are 4-byte aligned inside the packet: copy rather than dereference. */
    float x;
    int32_t state;
    memcpy(&state, (const void*)argv[2], sizeof(state));
    memcpy(&x, (const void*)argv[3], sizeof(x));
    received_state = state;
    received_x = x;
    ++received;
  }
  return 0;
}

static void send_pose(lo_address to, const char* path, double t, int seq, float x) {
  lo_send(to, path, "diifffffff", t, seq, 1, x, 0.0f, 1.7f, 0.0f, 0.0f, 0.0f, 1.0f);
}

/* Evaluates cond (over `stats`) until true, serving the liblo server meanwhile. The node's
   thread is bound to make it true: the 60 s deadline only stops a stuck run, never a slow one
   (CI runs the suite on a busy 2-core machine). */
#define WAIT_FOR(f, server, cond)             \
  do {                                        \
    const time_t deadline_ = time(NULL) + 60; \
    while (time(NULL) < deadline_) {          \
      coloc_fusion_get_stats((f), &stats);    \
      if (cond) break;                        \
      lo_server_recv_noblock((server), 10);   \
    }                                         \
    CHECK(cond);                              \
  } while (0)

static void check_options_and_arguments(void) {
  coloc_fusion_options options;
  coloc_pose pose;
  char error[256];

  CHECK(coloc_fusion_abi_version() == COLOC_FUSION_ABI_VERSION);
  coloc_fusion_default_options(&options);
  CHECK(options.process_noise == 0.001 && options.measurement_noise == 0.9);
  CHECK(options.gating == 1 && options.time_alignment == 1);

  /* Bad options are reported, not crashed on. */
  options.abi_version = 999;
  CHECK(coloc_fusion_create(&options, error, sizeof(error)) == NULL);
  CHECK(strstr(error, "abi_version") != NULL);
  coloc_fusion_default_options(&options);
  options.measurement_noise = -1.0;
  CHECK(coloc_fusion_create(&options, error, sizeof(error)) == NULL);
  CHECK(strstr(error, "measurement_noise") != NULL);
  coloc_fusion_default_options(&options);
  options.publish_url = "http://nowhere";
  CHECK(coloc_fusion_create(&options, error, sizeof(error)) == NULL);
  CHECK(strstr(error, "url") != NULL);
  coloc_fusion_destroy(NULL);
  memset(&pose, 0, sizeof(pose));
  CHECK(coloc_fusion_push_xr_pose(NULL, &pose, NULL, NULL) == COLOC_ERROR_INVALID_ARGUMENT);

  /* What bindings in other languages check at load: the structs' sizes and the status names. */
  CHECK(coloc_fusion_struct_size(COLOC_FUSION_STRUCT_POSE) == sizeof(coloc_pose));
  CHECK(coloc_fusion_struct_size(COLOC_FUSION_STRUCT_OPTIONS) == sizeof(coloc_fusion_options));
  CHECK(coloc_fusion_struct_size(COLOC_FUSION_STRUCT_STATS) == sizeof(coloc_fusion_stats));
  CHECK(coloc_fusion_struct_size(3) == 0 && coloc_fusion_struct_size(-1) == 0);
  CHECK(strcmp(coloc_fusion_status_name(COLOC_ERROR_NETWORK), "COLOC_ERROR_NETWORK") == 0);
  CHECK(strcmp(coloc_fusion_status_name(COLOC_OK), "COLOC_OK") == 0);
  CHECK(strcmp(coloc_fusion_status_name(99), "unknown status") == 0);
}

/* Headset and global poses over UDP from liblo to the handle's port; fused poses back to a
 * liblo server; counters for the garbage in between. */
static void check_osc(coloc_fusion* f, lo_server server) {
  coloc_pose pose, fused;
  coloc_fusion_stats stats;
  char port_text[16];
  int state = -1;
  time_t deadline;
  lo_address to;

  memset(&pose, 0, sizeof(pose));
  pose.orientation[3] = 1.0;
  pose.position[0] = NAN;
  CHECK(coloc_fusion_push_xr_pose(f, &pose, &fused, &state) == COLOC_ERROR_INVALID_ARGUMENT);
  CHECK(strlen(coloc_fusion_last_error(f)) > 0);
  CHECK(coloc_fusion_push_global_pose(f, &pose, 7) == COLOC_ERROR_INVALID_ARGUMENT);

  CHECK(coloc_fusion_osc_port(f) > 0);
  CHECK(coloc_fusion_start_osc(f) == COLOC_OK);
  snprintf(port_text, sizeof(port_text), "%d", coloc_fusion_osc_port(f));
  to = lo_address_new("127.0.0.1", port_text);
  send_pose(to, "/coloc/xr_pose", 1.0, 1, 0.0f);
  WAIT_FOR(f, server, stats.xr_poses >= 1);
  send_pose(to, "/coloc/pose", 1.0, 1, 2.0f); /* global: 2 m further in x -> D = +2 m */
  WAIT_FOR(f, server, stats.initialized >= 1);
  lo_send(to, "/coloc/pose", "s", "garbage"); /* wrong types: counted, dropped */
  WAIT_FOR(f, server, stats.osc_wrong_types >= 1);
  send_pose(to, "/coloc/xr_pose", 1.1, 2, 0.5f);
  WAIT_FOR(f, server, stats.xr_poses >= 2);
  deadline = time(NULL) + 60;
  while (received_state != COLOC_FUSION_TRACKING && time(NULL) < deadline) {
    lo_server_recv_noblock(server, 10);
  }
  CHECK(received >= 1);
  CHECK(received_state == COLOC_FUSION_TRACKING);
  CHECK(fabs(received_x - 2.5) < 1e-4);

  /* The direct API sees the same state. */
  CHECK(coloc_fusion_get_fused_pose(f, &fused, &state) == COLOC_OK);
  CHECK(state == COLOC_FUSION_TRACKING);
  CHECK(fabs(fused.position[0] - 2.5) < 1e-4);
  CHECK(coloc_fusion_get_stats(f, &stats) == COLOC_OK);
  CHECK(stats.osc_published >= 1);
  CHECK(stats.osc_wrong_types == 1);
  CHECK(coloc_fusion_stop_osc(f) == COLOC_OK);
  lo_address_free(to);
}

int main(void) {
  coloc_fusion_options options;
  coloc_fusion* f;
  char url[64];
  lo_server server;

  check_options_and_arguments();

  /* A liblo server in C receives the fused poses. */
  server = lo_server_new_with_proto(NULL, LO_UDP, NULL);
  CHECK(server != NULL);
  if (server == NULL) return 1;
  lo_server_add_method(server, "/coloc/fused_pose", NULL, on_fused, NULL);
  snprintf(url, sizeof(url), "osc.udp://127.0.0.1:%d", lo_server_get_port(server));

  coloc_fusion_default_options(&options);
  options.publish_url = url;
  f = coloc_fusion_create(&options, NULL, 0);
  CHECK(f != NULL);
  if (f != NULL) check_osc(f, server);
  coloc_fusion_destroy(f);
  lo_server_free(server);
  if (failures == 0) printf("fusion C ABI: all checks passed\n");
  return failures == 0 ? 0 : 1;
}
