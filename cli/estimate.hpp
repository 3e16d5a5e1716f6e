// The parts of estimate shared by its files: one input (cmd_estimate.cpp) and the batch
// (estimate_batch.cpp).
#pragma once

#include "estimate_args.hpp"
#include "estimate_report.hpp"

namespace nhcli {

/// Reads o.in, estimates, orients and writes o.out (in memory, or out of core with --stream);
/// fills o's counts and seconds. Throws on failure; exit-4 and exit-7 errors name the input.
void estimate_file(const EstimateArgs& a, const Setup& st, Outcome& o);

/// -o DIR: every input (or every cloud in an input directory) in turn; one failure does not stop
/// the rest (unless --fail-fast). Returns 0, 10 (an input failed), 130 or 143 (interrupted).
int run_batch(const EstimateArgs& a, const Setup& st);

}  // namespace nhcli
