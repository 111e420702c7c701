// Exit codes of the fascia program (sysexits.h): the command-line contract of DESIGN.md, listed in
// the README.
#pragma once

namespace fascia::app {

enum ExitCode : int {
  kOk = 0,
  kSolverFailed = 1,  // Newton did not converge, or the state or energies became non-finite
  kUsage = 64,
  kDataError = 65,
  kNoInput = 66,
  kUnavailable = 69,  // a required service is missing: --backend cuda without a usable CUDA device
  kSoftware = 70,     // an internal error: an exception fascia does not expect from any input (a defect)
  kTooLarge = 71,     // refused for size: more memory than --max-memory, more device memory than is free, more disk than is free, an input over its cap
  kCantCreate = 73,   // the output exists (no --overwrite or --resume) or is one of the run's inputs
  kIoError = 74,
  kStoppedOnSignal = 75,
  kBadScene = 78,
};

}  // namespace fascia::app
