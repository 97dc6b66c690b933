#pragma once
// SIGINT / SIGTERM taken synchronously (sigwait / sigtimedwait) by the verbs that run until
// stopped: `coloc view`, `coloc record`, and `coloc map|localize` with a live camera or viewer.
#include <csignal>

namespace coloc::cli {

// SIGINT and SIGTERM.
sigset_t stop_signals();

// Blocks them in this thread and every thread started after it (call first), and gives them
// their default disposition: a shell starts background jobs with SIGINT ignored, and an ignored
// signal is discarded even while blocked; with the default one it stays pending for sigwait.
void block_stop_signals();

}  // namespace coloc::cli
