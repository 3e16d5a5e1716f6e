// Exceptions thrown by the core. Front ends map them to exit codes / host-app messages:
// InvalidOptions -> 2 (usage), InputError -> 3 (unreadable or malformed input),
// UnprocessableInput -> 4 (readable but too few valid points), ModelError -> 5 (NH-Net model
// missing, unreadable or not made for this build), OutputError -> 6 (cannot write),
// DeviceUnavailable -> 8 (the requested compute device is not there),
// Cancelled -> 130 / 143 (the progress callback asked to stop: SIGINT / SIGTERM in the CLI).
#pragma once

#include <stdexcept>
#include <string>

namespace nhnet {

/// A parameter is out of range or options conflict. Message says which and what is allowed.
class InvalidOptions : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// An input file cannot be read or is malformed. Message names the file and the problem.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The input is well formed but cannot be processed (e.g. fewer than 3 finite points).
class UnprocessableInput : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The NH-Net model file is missing, truncated, corrupt, or its metadata does not match this
/// build's descriptor. Message names the model file and the mismatch. (An InputError, so code
/// that catches input errors still sees it.)
class ModelError : public InputError {
 public:
  using InputError::InputError;
};

/// The requested device (e.g. --device cuda) is not available; never a silent fallback.
class DeviceUnavailable : public InvalidOptions {
 public:
  using InvalidOptions::InvalidOptions;
};

/// An output file cannot be written. Message names the file and the reason.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The progress callback returned false; the work was abandoned and nothing was written.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace nhnet
