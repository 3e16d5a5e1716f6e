// nhnet-cli's subcommands as main.cpp sees them: each adds its CLI11 sub-app and says what to run.
#pragma once

#include <functional>

namespace CLI {
class App;
}

namespace nhcli {

/// A subcommand: its CLI11 sub-app and what to run when it was selected.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command add_estimate_command(CLI::App& parent);  // cmd_estimate.cpp
Command add_eval_command(CLI::App& parent);      // cmd_eval.cpp
Command add_denoise_command(CLI::App& parent);   // cmd_denoise.cpp

}  // namespace nhcli
