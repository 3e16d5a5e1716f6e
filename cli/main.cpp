// nhnet-cli: command-line front end of the nhnet core. Parses arguments (CLI11), dispatches to a
// subcommand and maps every failure to one stderr line and a documented exit code:
//   0 ok, 1 internal error, 2 usage / bad parameter, 3 unreadable or malformed input,
//   4 input readable but unprocessable, 5 bad NH-Net model, 6 cannot write output, 7 out of
//   memory, 8 device unavailable, 10 batch with failed inputs, 130 SIGINT, 143 SIGTERM.
#include "args.hpp"
#include "commands.hpp"
#include "errors.hpp"
#include "progress.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/version.hpp"

#include <CLI/CLI.hpp>

#include <csignal>
#include <iostream>
#include <new>
#include <vector>

namespace {

const char* kExitCodes =
    "Exit codes:\n"
    "  0    success\n"
    "  1    internal error\n"
    "  2    usage error or bad parameter\n"
    "  3    input unreadable or malformed (missing file, directory, garbage, truncated)\n"
    "  4    input readable but unprocessable (too few finite points)\n"
    "  5    NH-Net model missing, truncated, corrupt or not made for this version\n"
    "  6    output cannot be written (exists without --overwrite, same as input, no directory)\n"
    "  7    out of memory\n"
    "  8    requested device not available (--device cuda without CUDA)\n"
    "  10   batch (estimate -o DIR): at least one input failed; the others were written\n"
    "  130  interrupted by SIGINT (Ctrl-C); no output is left behind\n"
    "  143  terminated by SIGTERM; no output is left behind\n";

int fail(int code, const std::string& message) {
  nhcli::print_error(message);
  return code;
}

int run_guarded(const std::function<int()>& run) {
  try {
    return run();
  } catch (...) {
    std::string message;
    const int code = nhcli::classify_current_exception(message);
    return fail(code, message);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "nhnet-cli: normal estimation for unstructured point clouds (PLY, PCD, XYZ, LAS/LAZ, E57).",
      "nhnet-cli"};
  app.set_version_flag("--version", std::string("nhnet-cli ") + nhnet::version(),
                       "Print the version and exit");
  app.require_subcommand(1);
  app.footer(std::string("Run 'nhnet-cli SUBCOMMAND --help' for the options of a subcommand.\n\n") +
             kExitCodes);

  std::vector<nhcli::Command> commands;
  try {
    commands.push_back(nhcli::add_estimate_command(app));
    commands.push_back(nhcli::add_eval_command(app));
    commands.push_back(nhcli::add_denoise_command(app));
  } catch (const std::exception& e) {
    return fail(nhcli::kFailure, std::string("internal error: ") + e.what());
  }

  if (argc > 1 && argv[1][0] != '-') {  // a mistyped subcommand: say so, not "one is required"
    bool known = false;
    std::string names;
    for (const auto& c : commands) {
      known = known || c.app->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + c.app->get_name();
    }
    if (!known)
      return fail(nhcli::kUsage, std::string("unknown subcommand '") + argv[1] +
                                     "' (expected one of: " + names + "; see 'nhnet-cli --help')");
  }

  try {
    app.parse(nhcli::cli_args(argc, argv));
  } catch (const CLI::Success& e) {  // --help, --help-all, --version
    return app.exit(e) == 0 ? nhcli::kOk : nhcli::kUsage;
  } catch (const CLI::ParseError& e) {
    std::string hint = "nhnet-cli --help";
    for (const auto& c : commands)
      if (c.app->parsed()) hint = "nhnet-cli " + c.app->get_name() + " --help";
    return fail(nhcli::kUsage, std::string(e.what()) + " (see '" + hint + "')");
  }

  nhcli::install_signal_handlers();
  for (const auto& c : commands)
    if (c.app->parsed()) return run_guarded(c.run);
  return fail(nhcli::kUsage, "no subcommand given (see 'nhnet-cli --help')");
}
