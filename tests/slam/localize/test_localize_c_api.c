/* The localizer's C ABI from C99: the header compiles as C, the library links, and failures are
 * status codes with messages naming the file (the real localization through this ABI is in
 * test_localizer.cpp, on the test map). */
#include <stdio.h>
#include <string.h>

#include "slam/localize/c_api.h"

int main(void) {
  char error[512];
  coloc_localizer* h;
  if (coloc_localize_abi_version() != COLOC_LOCALIZE_ABI_VERSION) {
    printf("ABI version mismatch\n");
    return 1;
  }
  h = coloc_localizer_open("/nonexistent/site.db", "/nonexistent/vocabulary.cvoc", NULL, error,
                           sizeof error);
  if (h != NULL || strstr(error, "/nonexistent/") == NULL) {
    printf("open of a missing file: handle %p, message '%s'\n", (void*)h, error);
    return 1;
  }
  if (coloc_localizer_open(NULL, NULL, NULL, error, sizeof error) != NULL || error[0] == '\0') {
    printf("open with NULL paths did not fail with a message\n");
    return 1;
  }
  if (coloc_localizer_localize(NULL, NULL, 0, 0, 0, 0, NULL, 0, 0.0, NULL) !=
          COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT ||
      coloc_localizer_reset(NULL) != COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT) {
    printf("a NULL handle was not refused\n");
    return 1;
  }
  if (coloc_localizer_anchor_to_scan(NULL, NULL, 0) != COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT) {
    printf("coloc_localizer_anchor_to_scan accepted a NULL handle\n");
    return 1;
  }
  coloc_localizer_close(NULL);
  /* The helpers of bindings in other languages: the struct's size and the status names. */
  if (coloc_localize_pose_size() != sizeof(coloc_localize_pose) ||
      strcmp(coloc_localize_status_name(COLOC_LOCALIZE_ERROR_FILE), "COLOC_LOCALIZE_ERROR_FILE") !=
          0 ||
      strcmp(coloc_localize_status_name(42), "unknown status") != 0) {
    printf("coloc_localize_pose_size / coloc_localize_status_name disagree with the header\n");
    return 1;
  }
  printf("ok: %s\n", error);
  return 0;
}
