/* The installed fusion C library from C, as an engine plugin links it: the header's ABI
 * version agrees with the library's, and one headset pose goes through a fuser. */
#include <stdio.h>

#include "fusion/c_api.h"

int main(void) {
  coloc_fusion_options options;
  coloc_pose xr = {0.0, {0.0, 0.0, 1.7}, {0.0, 0.0, 0.0, 1.0}}, fused;
  char error[256];
  int state = -1;
  coloc_fusion* fusion;
  if (coloc_fusion_abi_version() != COLOC_FUSION_ABI_VERSION) {
    fprintf(stderr, "ABI %d in the library, %d in the header\n", coloc_fusion_abi_version(),
            COLOC_FUSION_ABI_VERSION);
    return 1;
  }
  coloc_fusion_default_options(&options);
  fusion = coloc_fusion_create(&options, error, sizeof(error));
  if (fusion == NULL) {
    fprintf(stderr, "coloc_fusion_create: %s\n", error);
    return 1;
  }
  if (coloc_fusion_push_xr_pose(fusion, &xr, &fused, &state) != COLOC_OK) {
    fprintf(stderr, "push_xr_pose: %s\n", coloc_fusion_last_error(fusion));
    coloc_fusion_destroy(fusion);
    return 1;
  }
  printf("consumer_c: fusion ABI %d, fused z %.2f m, state %d\n", coloc_fusion_abi_version(),
         fused.position[2], state);
  coloc_fusion_destroy(fusion);
  return 0;
}
