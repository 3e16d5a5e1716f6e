// What nhnet-cli shows while it works, and how it stops: the progress bar and warnings on stderr,
// and the SIGINT/SIGTERM handlers whose flag the progress callback hands to the core as cancel.
#pragma once

#include "nhnet/progress.hpp"

#include <chrono>
#include <string>

namespace nhcli {

// ---- signals ------------------------------------------------------------------------------------

/// Installs SIGINT (unless it is ignored, as for background jobs of scripts) and SIGTERM handlers
/// that only set a flag; the first signal restores the default action, so a second one kills.
void install_signal_handlers();
/// The signal received (SIGINT / SIGTERM), 0 when none.
int interrupted();
/// Throws nhnet::Cancelled when a signal was received.
void throw_if_interrupted();

// ---- stderr reporting ---------------------------------------------------------------------------

/// Progress bar on stderr (only when stderr is a terminal and not --quiet) plus warnings that
/// never collide with it. The progress callback also carries the cancel flag to the core.
class Reporter {
 public:
  explicit Reporter(bool quiet);
  ~Reporter();
  Reporter(const Reporter&) = delete;
  Reporter& operator=(const Reporter&) = delete;

  /// Shows `stage` at `fraction` (throttled to ~10 redraws per second).
  void stage(const std::string& name, double fraction = 0.0);
  /// Callback for nhnet::RunContext: updates the bar, returns false once interrupted. The
  /// call's own [0, 1] is shown as [begin, end] of the bar (for commands with several calls).
  nhnet::ProgressCallback callback(double begin = 0.0, double end = 1.0);
  /// Prints "nhnet-cli: warning: <message>" on stderr.
  void warn(const std::string& message);
  /// Removes the bar from the terminal (idempotent).
  void clear();
  /// Seconds since construction.
  double elapsed() const;
  bool quiet() const { return quiet_; }

 private:
  void draw(double fraction, const std::string& stage, bool force);

  bool quiet_;
  bool bar_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::string last_stage_;
};

}  // namespace nhcli
