// eval's arguments: EST GT --json, their CLI11 wiring and help texts.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace nhcli {

/// eval's command line.
struct EvalArgs {
  std::string est, gt;
  bool json = false;
};

/// Adds eval's EST GT, --json and footer to `sub`.
void add_eval_options(CLI::App* sub, EvalArgs& a);

}  // namespace nhcli
