#pragma once
// The version of coloc this program was built from: the project's release number (CMake's
// project version) and the git commit of the checkout ("-dirty" when it had uncommitted
// changes, "unknown" when built outside git). For `coloc --version` and the logs of a run.
#include <string_view>

namespace coloc {

std::string_view version();   // "0.1.0"
std::string_view git_hash();  // "e7254f9c0a1b", "e7254f9c0a1b-dirty" or "unknown"

}  // namespace coloc
