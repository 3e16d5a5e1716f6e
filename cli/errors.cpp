// Maps exceptions to nhnet-cli's exit codes and one-line messages (README "Exit codes").
#include "errors.hpp"

#include "progress.hpp"

#include <algorithm>
#include <csignal>
#include <exception>
#include <iostream>

namespace nhcli {

int signal_exit_code(int sig) { return sig == SIGTERM ? kTerminated : kInterrupted; }

bool is_signal_exit(int code) { return code == kInterrupted || code == kTerminated; }

namespace {

template <class E>
bool is_a(const std::exception& e) {
  return dynamic_cast<const E*>(&e) != nullptr;
}

/// The exit code of `e`: the first type it is, in this order (derived errors before their base).
int exit_code_of(const std::exception& e) {
  if (is_a<nhnet::DeviceUnavailable>(e)) return kDevice;  // an InvalidOptions
  if (is_a<nhnet::InvalidOptions>(e)) return kUsage;
  if (is_a<nhnet::ModelError>(e)) return kModel;  // an InputError
  if (is_a<nhnet::InputError>(e)) return kInput;
  if (is_a<nhnet::UnprocessableInput>(e)) return kUnprocessable;
  if (is_a<nhnet::OutputError>(e)) return kOutput;
  if (is_a<std::bad_alloc>(e)) return kMemory;
  return kFailure;
}

}  // namespace

int classify_current_exception(std::string& message) {
  try {
    throw;
  } catch (const nhnet::Cancelled&) {
    const int sig = interrupted();
    message = std::string("interrupted") +
              (sig == SIGTERM  ? " (SIGTERM)"
               : sig == SIGINT ? " (SIGINT)"
                               : "") +
              "; no output written";
    return signal_exit_code(sig);
  } catch (const std::exception& e) {
    const int code = exit_code_of(e);
    if (code == kFailure)
      message = std::string("internal error: ") + e.what();
    else if (code == kMemory && !is_a<OutOfMemory>(e))
      message = "out of memory";
    else
      message = e.what();
    return code;
  } catch (...) {
    message = "internal error: unknown exception";
    return kFailure;
  }
}

std::string one_line(std::string text) {
  const auto blank = [](char c) { return c == '\n' || c == '\r' || c == '\t'; };
  std::replace_if(text.begin(), text.end(), blank, ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

void print_error(const std::string& message) {
  std::cerr << "nhnet-cli: error: " << one_line(message) << std::endl;
}

}  // namespace nhcli
