// estimate's per-input outcomes and what is reported of them besides the summary lines: the
// --report JSON file (one input or a batch) and the batch's closing lines on stderr.
#pragma once

#include "estimate_args.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace nhcli {

/// One input's outcome, for the batch's closing line and --report.
struct Outcome {
  std::string in, out;
  std::string status = "skipped";  ///< ok / failed / interrupted / skipped (not run)
  int exit_code = -1;
  std::string error;
  int64_t points = -1, failed = -1;
  std::string orient;         ///< the orientation applied ("" = not reached)
  std::string orient_source;  ///< why (OrientPlan::source, orient/auto.hpp)
  double seconds = 0;
};

/// Marks `o` as written.
void record_success(Outcome& o);
/// Inside a catch block: records the exception being handled in `o` (exit code, one-line error,
/// status failed or interrupted). With `name_input`, an error that does not name the input gets
/// "IN: " in front.
void record_failure(Outcome& o, bool name_input);

/// Writes the --report file `path` (a temporary file + rename, so a reader never sees half of
/// it; nhnet::OutputError, exit 6, on failure).
void write_report(const std::string& path, const Setup& st, const std::vector<Outcome>& outcomes,
                  double seconds);
/// Prints the batch's closing line (and the interruption's) on stderr; returns the batch's exit
/// code: 130 / 143 when interrupted, 10 when an input failed, else 0.
int finish_batch(const std::vector<Outcome>& outcomes);

}  // namespace nhcli
