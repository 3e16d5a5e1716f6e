// Shared helpers of nhnet-cli: exit codes, strict parameter parsing, stderr reporting (warnings,
// progress bar), SIGINT/SIGTERM -> cancel flag, and a tiny JSON writer. No algorithm lives here.
#pragma once

#include "nhnet/io/cloud.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/orient/orient.hpp"
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
  kModel = 5,          ///< NH-Net model missing, truncated, corrupt or made for another build
  kOutput = 6,         ///< output cannot be written (or refused: exists, same as input, ...)
  kMemory = 7,         ///< out of memory
  kDevice = 8,         ///< the requested device (--device cuda) is not available
  kBatch = 10,         ///< batch run: at least one input failed (the others were processed)
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
Command add_denoise_command(CLI::App& parent);

/// Inside a catch block: the exit code of the exception being handled and its one-line message
/// (the mapping of README "Exit codes"; a Cancelled maps to 130 or 143 by the signal received).
int classify_current_exception(std::string& message);

/// Runs f() (the processing of input IN); an nhnet::UnprocessableInput from it is rethrown with
/// "IN: " in front and std::bad_alloc as OutOfMemory naming IN, so exit-4 and exit-7 errors name
/// the file like every other error. Used by every subcommand that processes one cloud.
template <class F>
auto naming_file(const std::string& in, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const nhnet::UnprocessableInput& e) {
    const std::string what = e.what();
    if (what.compare(0, in.size() + 2, in + ": ") == 0) throw;  // named already
    throw nhnet::UnprocessableInput(in + ": " + what);
  } catch (const OutOfMemory&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw OutOfMemory(in + ": out of memory (the cloud needs more memory than this process may "
                      "use; no output written)");
  }
}

// ---- parameters --------------------------------------------------------------------------------

/// Parses a whole string as a decimal integer >= `min`; throws nhnet::InvalidOptions with a
/// message naming `option` otherwise.
int parse_int(const std::string& option, const std::string& text, int min);
/// Parses a whole string as an unsigned 64-bit decimal integer.
uint64_t parse_u64(const std::string& option, const std::string& text);
/// "auto" (or empty) -> {}; "50,100,150" -> {50, 100, 150}; every value an integer >= 3.
std::vector<int> parse_scales(const std::string& text);

/// The default normal estimator: "nhnet" when it can run (this build links libtorch and the
/// shipped model file is there), else "mfps" with `why` saying why nhnet could not.
std::string default_method(std::string& why);
/// Parses a whole string as a finite decimal number > `above` (strictly).
double parse_double(const std::string& option, const std::string& text, double above);
/// The value of --orient: "keep", "none", "mst", "mst:K" (K >= 2), "viewpoint:X,Y,Z".
nhnet::OrientOptions parse_orient(const std::string& text);
/// argv as CLI11 wants it (reversed), with "--orient viewpoint X Y Z" joined into the single
/// value "--orient=viewpoint:X,Y,Z", so --orient takes exactly one value and can never swallow
/// the positional arguments that follow it.
std::vector<std::string> cli_args(int argc, char** argv);

// ---- shared arguments ----------------------------------------------------------------------------

/// The positional IN OUT of a command that reads one cloud and writes one.
void add_in_out(CLI::App* sub, std::string& in, std::string& out);
/// --ascii, --overwrite, -q/--quiet, --json of a command that writes a cloud.
void add_output_flags(CLI::App* sub, bool& ascii, bool& overwrite, bool& quiet, bool& json);

// ---- files ---------------------------------------------------------------------------------------

/// Output path checks done before reading anything (nhnet::OutputError, exit 6): OUT is the
/// input, exists without `overwrite`, is a directory, or its directory is missing / not writable.
void check_output(const std::string& in, const std::string& out, bool overwrite);
/// Throws nhnet::InvalidOptions (exit 2) when OUT's extension names no format we write.
void check_output_format(const std::string& out);

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

// ---- input / output ------------------------------------------------------------------------------

/// Reads IN (exit 3 on failure) with a "reading" stage, prints the reader's warnings and keeps
/// them in `warnings` (their count goes into the JSON summary).
nhnet::Cloud read_input(Reporter& rep, const std::string& in, std::vector<std::string>& warnings);
/// Writes OUT (exit 6 on failure; a temporary file + rename) with a "writing" stage.
void write_output(Reporter& rep, const std::string& out, const nhnet::Cloud& cloud, bool ascii);

// ---- orientation ---------------------------------------------------------------------------------

/// Warns about normals / connected parts that could not be oriented (nothing when all were).
void warn_unoriented(Reporter& rep, const nhnet::OrientOptions& opt, const nhnet::OrientResult& r);
/// Summary-line text: "mst (2 parts, 0 unoriented, 1234 flipped)", "keep (12 flipped)", "none".
std::string orient_summary(const nhnet::OrientOptions& opt, const nhnet::OrientResult& r);
/// JSON members: "orient": "...", "flipped": N, "unoriented": N, "components": N, ...
std::string orient_json(const nhnet::OrientOptions& opt, const nhnet::OrientResult& r);

// ---- output helpers ------------------------------------------------------------------------------

/// One line: newlines and tabs in `text` become spaces.
std::string one_line(std::string text);
/// JSON string literal (quoted, escaped).
std::string json_string(const std::string& text);
/// JSON number (%.*g), `null` when not finite.
std::string json_number(double value, int precision = 6);

}  // namespace nhcli
