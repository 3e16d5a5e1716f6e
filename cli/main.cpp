// nhnet-cli: command-line front end of the nhnet core. Parses arguments (CLI11), dispatches to a
// subcommand and maps every failure to one stderr line and a documented exit code:
//   0 ok, 1 internal error, 2 usage / bad parameter, 3 unreadable or malformed input,
//   4 input readable but unprocessable, 6 cannot write output, 7 out of memory, 130 SIGINT,
//   143 SIGTERM.
#include "common.hpp"

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
    "  6    output cannot be written (exists without --overwrite, same as input, no directory)\n"
    "  7    out of memory\n"
    "  130  interrupted by SIGINT (Ctrl-C); no output is left behind\n"
    "  143  terminated by SIGTERM; no output is left behind\n";

int fail(int code, const std::string& message) {
  std::cerr << "nhnet-cli: error: " << nhcli::one_line(message) << std::endl;
  return code;
}

int run_guarded(const std::function<int()>& run) {
  try {
    return run();
  } catch (const nhnet::Cancelled&) {
    const int sig = nhcli::interrupted();
    return fail(sig == SIGTERM ? nhcli::kTerminated : nhcli::kInterrupted, std::string("interrupted") +
                                         (sig == SIGTERM ? " (SIGTERM)" : sig == SIGINT ? " (SIGINT)" : "") +
                                         "; no output written");
  } catch (const nhnet::InvalidOptions& e) {
    return fail(nhcli::kUsage, e.what());
  } catch (const nhnet::InputError& e) {
    return fail(nhcli::kInput, e.what());
  } catch (const nhnet::UnprocessableInput& e) {
    return fail(nhcli::kUnprocessable, e.what());
  } catch (const nhnet::OutputError& e) {
    return fail(nhcli::kOutput, e.what());
  } catch (const std::bad_alloc& e) {
    const bool named = dynamic_cast<const nhcli::OutOfMemory*>(&e) != nullptr;
    return fail(nhcli::kMemory, named ? e.what() : "out of memory");
  } catch (const std::exception& e) {
    return fail(nhcli::kFailure, std::string("internal error: ") + e.what());
  } catch (...) {
    return fail(nhcli::kFailure, "internal error: unknown exception");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"nhnet-cli: normal estimation for unstructured point clouds (PLY, PCD, XYZ).",
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
      return fail(nhcli::kUsage, std::string("unknown subcommand '") + argv[1] + "' (expected one of: " +
                                     names + "; see 'nhnet-cli --help')");
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
