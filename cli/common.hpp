// Shared helpers of nhnet-cli: exit codes, strict parameter parsing, stderr reporting (warnings,
// progress bar), SIGINT/SIGTERM -> cancel flag, and a tiny JSON writer. No algorithm lives here.
#pragma once

#include "nhnet/progress.hpp"

#include <chrono>
#include <cstdint>
#include <functional>
#include <new>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace nhcli {

/// Documented exit codes (README "Exit codes"; notes/reliability.md).
enum ExitCode : int {
  kOk = 0,
  kFailure = 1,        ///< unexpected internal error
  kUsage = 2,          ///< usage or bad parameter
  kInput = 3,          ///< input unreadable or malformed
  kUnprocessable = 4,  ///< input readable but cannot be processed (too few finite points)
  kOutput = 6,         ///< output cannot be written (or refused: exists, same as input, ...)
  kMemory = 7,         ///< out of memory
  kInterrupted = 130,  ///< SIGINT (128 + 2, the shell's convention)
  kTerminated = 143,   ///< SIGTERM (128 + 15)
};

/// std::bad_alloc with a message naming the file being processed (exit 7).
class OutOfMemory : public std::bad_alloc {
 public:
  explicit OutOfMemory(std::string message) : message_(std::move(message)) {}
  const char* what() const noexcept override { return message_.c_str(); }

 private:
  std::string message_;
};

/// A subcommand: its CLI11 sub-app and what to run when it was selected.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command add_estimate_command(CLI::App& parent);
Command add_eval_command(CLI::App& parent);

// ---- parameters --------------------------------------------------------------------------------

/// Parses a whole string as a decimal integer >= `min`; throws nhnet::InvalidOptions with a
/// message naming `option` otherwise.
int parse_int(const std::string& option, const std::string& text, int min);
/// Parses a whole string as an unsigned 64-bit decimal integer.
uint64_t parse_u64(const std::string& option, const std::string& text);
/// "auto" (or empty) -> {}; "50,100,150" -> {50, 100, 150}; every value an integer >= 3.
std::vector<int> parse_scales(const std::string& text);

// ---- signals -------------------------------------------------------------------------------------

/// Installs SIGINT (unless it is ignored, as for background jobs of scripts) and SIGTERM handlers
/// that only set a flag; the first signal restores the default action, so a second one kills.
void install_signal_handlers();
/// The signal received (SIGINT / SIGTERM), 0 when none.
int interrupted();
/// Throws nhnet::Cancelled when a signal was received.
void throw_if_interrupted();

// ---- stderr reporting ----------------------------------------------------------------------------

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
  /// Callback for nhnet::RunContext: updates the bar, returns false once interrupted.
  nhnet::ProgressCallback callback();
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

// ---- output helpers ------------------------------------------------------------------------------

/// One line: newlines and tabs in `text` become spaces.
std::string one_line(std::string text);
/// JSON string literal (quoted, escaped).
std::string json_string(const std::string& text);
/// JSON number (%.*g), `null` when not finite.
std::string json_number(double value, int precision = 6);

}  // namespace nhcli
