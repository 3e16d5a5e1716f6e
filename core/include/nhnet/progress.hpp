// Progress reporting and cancellation shared by every long-running call of the core.
#pragma once

#include <functional>
#include <string>

namespace nhnet {

/// Called from the calling thread with the overall fraction done in [0, 1] and the name of the
/// current stage. Return false to cancel: the call then throws nhnet::Cancelled.
using ProgressCallback = std::function<bool(double fraction, const std::string& stage)>;

/// How a stage runs: thread count and progress. Stages never print.
struct RunContext {
  /// Worker threads for parallel loops; 0 = all cores (OpenMP default).
  int threads = 0;
  /// Optional progress/cancel callback; empty = no reporting.
  ProgressCallback progress;
};

}  // namespace nhnet
