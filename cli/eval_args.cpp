// eval's arguments: CLI11 wiring of EST GT --json and the help footer.
#include "eval_args.hpp"

#include <CLI/CLI.hpp>

namespace nhcli {

void add_eval_options(CLI::App* sub, EvalArgs& a) {
  sub->add_option("EST", a.est, "Cloud with estimated normals")->required();
  sub->add_option("GT", a.gt, "Cloud with ground-truth normals")->required();
  sub->add_flag("--json", a.json, "Print the result as one JSON object");
  sub->footer(
      "EST and GT hold the same points in the same order. Errors are unoriented angles\n"
      "acos(|n_est . n_gt|) in degrees: mean, RMS, and PGP5 / PGP10, the percentage of points\n"
      "under 5 / 10 degrees. Points whose normal is NaN or zero in either file are counted as\n"
      "invalid and left out.\n\n"
      "Example:\n"
      "  nhnet-cli estimate noisy.xyz est.xyzn && nhnet-cli eval est.xyzn noisy.gt.xyzn\n\n"
      "Exit codes: 0 ok, 2 point counts differ, 3 a file is unreadable or has no normals,\n"
      "4 no valid normal to compare.\n");
}

}  // namespace nhcli
