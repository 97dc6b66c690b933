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

// Waits for SIGINT/SIGTERM (blocked by block_stop_signals), at most `seconds` (< 0: no limit;
// 0: not at all), then unblocks them in this thread: a second signal while the verb shuts down
// (a stuck join, a slow save) ends the process by its default action instead of waiting forever.
void wait_for_stop_signal(double seconds);

}  // namespace coloc::cli
