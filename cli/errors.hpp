// Failures of nhnet-cli: the documented exit codes, the mapping of an exception to its exit code
// and one-line message, input-naming of exit-4 / exit-7 errors, and the "error:" line on stderr.
#pragma once

#include "nhnet/errors.hpp"

#include <new>
#include <string>
#include <utility>

namespace nhcli {

/// Documented exit codes (README "Exit codes"; docs/design/reliability.md#exit-codes).
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

/// Exit code for the signal `sig` received: 143 for SIGTERM, else 130.
int signal_exit_code(int sig);
/// Whether `code` is the exit code of a signal (130, 143).
bool is_signal_exit(int code);

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
    throw OutOfMemory(in +
                      ": out of memory (the cloud needs more memory than this process may "
                      "use; no output written)");
  }
}

/// One line: newlines and tabs in `text` become spaces.
std::string one_line(std::string text);
/// Prints "nhnet-cli: error: <message on one line>" on stderr.
void print_error(const std::string& message);

}  // namespace nhcli
