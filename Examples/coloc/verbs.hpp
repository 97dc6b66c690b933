#pragma once
// Each verb of the `coloc` CLI adds its subcommand to the app. A verb's callback returns
// normally on success and throws coloc::Error (exit 1) or CliFailure on failure; usage errors
// are CLI11 parse errors (exit 2).

#include <CLI/CLI.hpp>

namespace coloc::cli {

// A validator for durations and tolerances: a finite number >= 0 (CLI11's NonNegativeNumber
// lets "nan" through). A bad value is a usage error (exit 2) naming the option.
CLI::Validator non_negative_seconds();

// `bench` is the `coloc bench` subcommand: a verb adds its speed measurements under it.
void add_demo_verb(CLI::App& app);
void add_eval_verb(CLI::App& app);
// `eval` is the `coloc eval` subcommand (sequence diagnostics next to ate/rpe).
void add_frame_limit_verb(CLI::App& eval);
// `coloc eval table2` (verb_eval_table2.cpp).
void add_table2_verb(CLI::App& eval);
void add_vocab_verb(CLI::App& app, CLI::App& bench);
void add_map_verb(CLI::App& app, CLI::App& bench);
// `coloc localize` and `coloc bench localize` (verb_localize.cpp).
void add_localize_verb(CLI::App& app, CLI::App& bench);
// `coloc bench loop` (verb_loop_bench.cpp).
void add_loop_bench_verb(CLI::App& bench);
// `coloc mapdb ...` and `coloc bench mapdb` (verb_mapdb.cpp, verb_mapdb_bench.cpp).
void add_mapdb_verb(CLI::App& app, CLI::App& bench);
void add_e57_verb(CLI::App& app, CLI::App& bench);
void add_markers_verb(CLI::App& app, CLI::App& bench);
void add_twin_verb(CLI::App& app, CLI::App& bench);
void add_handeye_verb(CLI::App& app, CLI::App& bench);
void add_fuse_verb(CLI::App& app, CLI::App& bench);
// `coloc session ...` and `coloc bench session` (verb_session.cpp, verb_session_bench.cpp).
void add_session_verb(CLI::App& app, CLI::App& bench);
void add_session_bench(CLI::App& bench);
// `coloc devices`, `coloc devices make-replay`, `coloc bench capture` (verb_capture.cpp).
void add_capture_verb(CLI::App& app, CLI::App& bench);
// `coloc record` (verb_record.cpp).
void add_record_verb(CLI::App& app);
// `coloc calibrate` (verb_calibrate.cpp).
void add_calibrate_verb(CLI::App& app);
// `coloc register` (verb_register.cpp).
void add_register_verb(CLI::App& app);
// `coloc scan from-sequence` (verb_scan.cpp).
void add_scan_verb(CLI::App& app);
// `coloc view` and `coloc bench view` (verb_view.cpp, verb_view_bench.cpp).
void add_view_verb(CLI::App& app, CLI::App& bench);
void add_view_bench_verb(CLI::App& bench);
// `coloc bench site` (verb_bench_site.cpp).
void add_bench_site_verb(CLI::App& bench);

}  // namespace coloc::cli
