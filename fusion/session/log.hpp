#pragma once
// The session log (`coloc session --log FILE`): every accepted input as it arrived, one CSV line
// each, so a session can be analysed afterwards (`coloc session stability`):
//
//   receive_time,participant,device,time,sequence,state,tx,ty,tz,qx,qy,qz,qw
//
// receive_time: s on the session's clock (shared by all systems, unlike their own `time`);
// device: head, controller/<n>, global or anchor (participant empty); the pose in the frame it
// was sent in (vr_from_device for head and controllers, world frame for global and anchor).

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "fusion/session/config.hpp"
#include "fusion/session/node.hpp"
#include "fusion/session/simulate.hpp"  // StabilityRow

namespace coloc::fusion::session {

void write_log_header(std::ostream& out);
void write_log_record(std::ostream& out, const LogRecord& record);
// Throws coloc::Error naming the file, line and field.
std::vector<LogRecord> read_session_log(const std::filesystem::path& path);

// An et al.'s stability test from a session log: two controllers locked together (participant
// a's controller na, participant b's nb), paired by receive time within max_dt, their relative
// pose through the two calibrations of `config` (handeye::locked_controller_stability).
// Throws coloc::Error when a participant is unknown or no pairs match.
StabilityRow locked_stability(const std::vector<LogRecord>& log, const SessionConfig& config,
                              const std::string& a, int na, const std::string& b, int nb,
                              double max_dt = 0.01);

}  // namespace coloc::fusion::session
