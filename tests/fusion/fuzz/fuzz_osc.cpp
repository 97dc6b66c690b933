// libFuzzer target for OSC input (built by scripts/fuzz_osc with clang; not part of CI). Every
// input is one datagram: decoded (layout check, then liblo), and what decodes is handed to a
// fusion node's receive path, the receiver's clock advancing 11 ms per datagram, so the stream
// guards and the fuser see hostile times, sequences and poses. Any crash, sanitizer report or
// escaping exception is a finding; so is a decoded pose that is not finite and unit.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "fusion/osc.hpp"
#include "fusion/osc_node.hpp"

namespace {

struct Harness {
  coloc::fusion::FusionNode node{{}};
  double received = 0.0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // One node for the whole run: state carried across inputs is what a long-lived node has.
  static Harness* harness = new Harness();
  const coloc::fusion::OscDecodeResult r = coloc::fusion::decode_packet(data, size);
  if (r.messages.empty()) return 0;
  for (const coloc::fusion::OscMessage& m : r.messages) {
    const coloc::fusion::PoseMessage& p = m.pose;
    if (!std::isfinite(p.time) || !p.position.allFinite() ||
        std::abs(p.orientation.norm() - 1.0) > 1e-9) {
      std::abort();
    }
  }
  harness->received += 0.011;
  harness->node.handle({{0x7f000001u, 9}, r.messages, harness->received});
  const coloc::fusion::FusedPose out = harness->node.latest();
  if (!out.world_from_head.translation().allFinite()) std::abort();
  return 0;
}
