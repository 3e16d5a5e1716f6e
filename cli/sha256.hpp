// SHA-256 of a file (FIPS 180-4), for the model hash in `estimate --report`. Self-contained so
// the CLI needs no crypto library.
#pragma once

#include <string>

namespace nhcli {

/// Lower-case hex SHA-256 of the file's bytes; empty when the file cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace nhcli
