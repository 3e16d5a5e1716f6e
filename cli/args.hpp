// Options shared by nhnet-cli's commands: strict parsers of numbers, lists and --orient values,
// the argv rewrite for "--orient viewpoint X Y Z", the CLI11 wiring of options several commands
// take (IN OUT, --threads, --seed, output flags), and the
// "(default: ...)" ends of help texts, built from the core's defaults.
#pragma once

#include "nhnet/orient/orient.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace nhcli {

// ---- values -------------------------------------------------------------------------------------

/// Parses a whole string as a decimal integer >= `min`; throws nhnet::InvalidOptions with a
/// message naming `option` otherwise.
int parse_int(const std::string& option, const std::string& text, int min);
/// Parses a whole string as an unsigned 64-bit decimal integer.
uint64_t parse_u64(const std::string& option, const std::string& text);
/// "auto" (or empty) -> {}; "50,100,150" -> {50, 100, 150}; every value an integer >= 3.
std::vector<int> parse_scales(const std::string& text);
/// The text parse_scales reads back as `scales`: "auto" for {}, else "50,100,150".
std::string scales_text(const std::vector<int>& scales);
/// Parses a whole string as a finite decimal number > `above` (strictly).
double parse_double(const std::string& option, const std::string& text, double above);
/// The value of --orient: "auto", "keep", "none", "up", "mst", "mst:K" (K >= 2),
/// "viewpoint:X,Y,Z".
nhnet::OrientOptions parse_orient(const std::string& text);
/// argv as CLI11 wants it (reversed), with "--orient viewpoint X Y Z" joined into the single
/// value "--orient=viewpoint:X,Y,Z", so --orient takes exactly one value and can never swallow
/// the positional arguments that follow it.
std::vector<std::string> cli_args(int argc, char** argv);

// ---- help texts ---------------------------------------------------------------------------------

/// "(default: TEXT)", the end of an option's help text.
std::string default_note(const std::string& text);
/// A number as help texts write it (%g: 2, 0.35, 1e+06).
std::string number_text(double value);

// ---- shared options -----------------------------------------------------------------------------

/// The flags of a command that writes a cloud.
struct OutputFlags {
  bool ascii = false;      ///< --ascii
  bool overwrite = false;  ///< --overwrite
  bool quiet = false;      ///< -q, --quiet
  bool json = false;       ///< --json
};

/// The positional IN OUT of a command that reads one cloud and writes one.
void add_in_out(CLI::App* sub, std::string& in, std::string& out);
/// --ascii, --overwrite, -q/--quiet, --json of a command that writes a cloud.
void add_output_flags(CLI::App* sub, OutputFlags& flags);
/// --threads N (default: the core's, all cores).
void add_threads_option(CLI::App* sub, std::string& threads);
/// --seed S of MFPS's random plane samples (default: the core's).
void add_seed_option(CLI::App* sub, std::string& seed);
/// --precision P of the network (nhnet::kPrecisions; default: the core's).
void add_precision_option(CLI::App* sub, std::string& precision);
/// --precision's value, checked (nhnet::InvalidOptions naming the flag).
std::string parse_precision(const std::string& precision);

}  // namespace nhcli
