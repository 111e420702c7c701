// How `fascia run` answers signals and its wall-clock limit (docs/hpc.md):
//   SIGTERM, SIGINT, SIGUSR1, SIGQUIT  stop: the step in progress is abandoned (polled inside Newton
//                                      and the linear solver, core/stop_request.hpp), the last
//                                      completed step and a checkpoint are written, exit 75.
//                                      A second SIGINT ends the process at once (the checkpoint
//                                      on disk stays valid: io/checkpoint.hpp).
//   SIGUSR2                            write a checkpoint after the current step and go on.
//   SIGHUP                             ignored (the run outlives its terminal), and logged.
//   --max-wall DURATION                a SIGALRM timer that stops the run like SIGTERM.
#pragma once

#include <optional>
#include <string>

namespace fascia::app {

// The stop reason of --max-wall (stop reasons are signal numbers otherwise).
constexpr int kMaxWallReason = -1;

void install_stop_signals();
// Arms the --max-wall timer (seconds of wall time from now).
void arm_max_wall(double seconds);
// "SIGTERM", "--max-wall", ... for a stop reason.
std::string stop_reason_name(int reason);
// Whether SIGUSR2 asked for a checkpoint since the last call (clears the request).
bool take_checkpoint_request();
// Whether SIGHUP arrived since the last call (clears it).
bool take_hangup();

// Seconds of a duration given as a quantity ("90 min", "2 h", "3600 s", "3600") or as Slurm
// writes time limits ("[D-]HH:MM:SS", "MM:SS"); nullopt when unreadable or negative.
std::optional<double> parse_duration(const std::string& text);

}  // namespace fascia::app
