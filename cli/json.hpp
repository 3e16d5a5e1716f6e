// JSON literals for nhnet-cli's --json objects and --report file: strings and numbers.
#pragma once

#include <string>

namespace nhcli {

/// JSON string literal (quoted, escaped).
std::string json_string(const std::string& text);
/// JSON number (%.*g), `null` when not finite.
std::string json_number(double value, int precision = 6);

}  // namespace nhcli
