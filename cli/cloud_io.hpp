// The commands' files: checks of an output path before any work, reading the input cloud and
// writing the output cloud, with their stages and warnings on stderr.
#pragma once

#include "nhnet/io/cloud.hpp"

#include <string>
#include <vector>

namespace nhcli {

class Reporter;

/// Output path checks done before reading anything (nhnet::OutputError, exit 6): OUT is the
/// input, exists without `overwrite`, is a directory, or its directory is missing / not writable.
void check_output(const std::string& in, const std::string& out, bool overwrite);
/// Throws nhnet::InvalidOptions (exit 2) when OUT's extension names no format we write.
void check_output_format(const std::string& out);

/// Reads IN (exit 3 on failure) with a "reading" stage, prints the reader's warnings and keeps
/// them in `warnings` (their count goes into the JSON summary).
nhnet::Cloud read_input(Reporter& rep, const std::string& in, std::vector<std::string>& warnings);
/// Writes OUT (exit 6 on failure; a temporary file + rename) with a "writing" stage.
void write_output(Reporter& rep, const std::string& out, const nhnet::Cloud& cloud, bool ascii);

}  // namespace nhcli
