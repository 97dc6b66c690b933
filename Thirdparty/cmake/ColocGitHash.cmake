# Run at every build (cmake -P): writes OUT from IN with COLOC_GIT_HASH set to the checkout's
# commit ("-dirty" with uncommitted changes; "unknown" outside git). configure_file leaves OUT
# untouched when nothing changed, so an unchanged checkout recompiles nothing.
execute_process(COMMAND git -C "${SOURCE_DIR}" rev-parse --short=12 HEAD
                OUTPUT_VARIABLE COLOC_GIT_HASH OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE not_git ERROR_QUIET)
if(not_git)
  set(COLOC_GIT_HASH "unknown")
else()
  execute_process(COMMAND git -C "${SOURCE_DIR}" diff --quiet HEAD --
                  RESULT_VARIABLE dirty ERROR_QUIET)
  if(dirty)
    string(APPEND COLOC_GIT_HASH "-dirty")
  endif()
endif()
configure_file("${IN}" "${OUT}" @ONLY)
