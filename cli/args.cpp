// Strict option-value parsers, the --orient argv rewrite, the options several commands share and
// help-text defaults taken from the core.
#include "args.hpp"

#include "errors.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/progress.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace nhcli {

// ---- values -------------------------------------------------------------------------------------

namespace {

std::string quoted(const std::string& s) { return "'" + one_line(s) + "'"; }

/// `text` cut at each `sep`: "a,b" -> {"a", "b"}, "" -> {""}.
std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> items;
  for (size_t b = 0;;) {
    const size_t c = text.find(sep, b);
    items.push_back(text.substr(b, c == std::string::npos ? std::string::npos : c - b));
    if (c == std::string::npos) return items;
    b = c + 1;
  }
}

}  // namespace

int parse_int(const std::string& option, const std::string& text, int min) {
  int value = 0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(first, last, value);
  const std::string want =
      option + " must be an integer >= " + std::to_string(min) + ", got " + quoted(text);
  if (text.empty() || ec == std::errc::invalid_argument || ptr != last)
    throw nhnet::InvalidOptions(want);
  if (ec == std::errc::result_out_of_range) throw nhnet::InvalidOptions(want + " (out of range)");
  if (value < min) throw nhnet::InvalidOptions(want);
  return value;
}

uint64_t parse_u64(const std::string& option, const std::string& text) {
  uint64_t value = 0;
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), last, value);
  if (text.empty() || ec != std::errc() || ptr != last)
    throw nhnet::InvalidOptions(option + " must be an integer in [0, 2^64), got " + quoted(text));
  return value;
}

std::vector<int> parse_scales(const std::string& text) {
  std::vector<int> scales;
  if (text.empty() || text == "auto") return scales;
  for (const std::string& item : split(text, ',')) {
    int value = 0;
    const char* last = item.data() + item.size();
    const auto [ptr, ec] = std::from_chars(item.data(), last, value);
    if (item.empty() || ec != std::errc() || ptr != last || value < 3)
      throw nhnet::InvalidOptions(
          "--scales must be 'auto' or a comma-separated list of integers "
          ">= 3 (e.g. 50,100,150), got " +
          quoted(text));
    scales.push_back(value);
  }
  return scales;
}

std::string scales_text(const std::vector<int>& scales) {
  if (scales.empty()) return "auto";
  std::string s;
  for (const int v : scales) s += (s.empty() ? "" : ",") + std::to_string(v);
  return s;
}

double parse_double(const std::string& option, const std::string& text, double above) {
  double value = 0;
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), last, value);
  if (text.empty() || ec != std::errc() || ptr != last || !std::isfinite(value) || !(value > above))
    throw nhnet::InvalidOptions(option + " must be a number > " + number_text(above) + ", got " +
                                quoted(text));
  return value;
}

nhnet::OrientOptions parse_orient(const std::string& text) {
  const std::string usage =
      "--orient must be auto, keep, none, up, mst, mst:K (K >= 2) or viewpoint X Y Z, got " +
      quoted(text);
  const size_t colon = text.find(':');
  const std::string mode = text.substr(0, colon);
  const std::string values = colon == std::string::npos ? "" : text.substr(colon + 1);
  nhnet::OrientOptions opt;
  try {
    opt.mode = nhnet::orient_mode_from_string(mode);
  } catch (const nhnet::InvalidOptions&) {
    throw nhnet::InvalidOptions(usage);
  }
  if (opt.mode == nhnet::OrientMode::Mst && colon != std::string::npos)
    opt.k = parse_int("--orient mst:K", values, 2);
  else if (opt.mode == nhnet::OrientMode::Viewpoint) {
    const std::vector<std::string> xyz = split(values, ',');
    if (colon == std::string::npos || xyz.size() != 3)
      throw nhnet::InvalidOptions("--orient viewpoint needs 3 coordinates X Y Z, got " +
                                  quoted(text));
    for (int d = 0; d < 3; ++d)
      opt.viewpoint[d] = parse_double("--orient viewpoint " + std::string(1, char('X' + d)),
                                      xyz[size_t(d)], -HUGE_VAL);
  } else if (colon != std::string::npos || opt.mode == nhnet::OrientMode::Sensors) {
    throw nhnet::InvalidOptions(usage);  // sensors: only from the file, through auto
  }
  return opt;
}

std::vector<std::string> cli_args(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  for (size_t i = 0; i + 1 < args.size(); ++i)
    if (args[i] == "--orient" && args[i + 1] == "viewpoint") {
      const size_t n = std::min<size_t>(3, args.size() - i - 2);
      std::string joined = "--orient=viewpoint:";
      for (size_t j = 0; j < n; ++j) joined += (j ? "," : "") + args[i + 2 + j];
      args.erase(args.begin() + long(i) + 1, args.begin() + long(i + 2 + n));
      args[i] = joined;
    }
  std::reverse(args.begin(), args.end());
  return args;
}

// ---- help texts ---------------------------------------------------------------------------------

std::string default_note(const std::string& text) { return "(default: " + text + ")"; }

std::string number_text(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", value);
  return buf;
}

// ---- shared options -----------------------------------------------------------------------------

void add_in_out(CLI::App* sub, std::string& in, std::string& out) {
  sub->add_option("IN", in, "Input cloud (.ply, .pcd, .xyz/.xyzn/.txt; content is sniffed)")
      ->required();
  sub->add_option("OUT", out,
                  "Output cloud; the format follows the extension (.ply, .pcd, .xyz/.xyzn/.txt)")
      ->required();
}

void add_output_flags(CLI::App* sub, OutputFlags& flags) {
  sub->add_flag("--ascii", flags.ascii, "Write PLY/PCD as ascii instead of binary");
  sub->add_flag("--overwrite", flags.overwrite, "Replace OUT if it exists (never the input)");
  sub->add_flag("-q,--quiet", flags.quiet,
                "No progress bar and no summary line (warnings and errors still go to stderr)");
  sub->add_flag("--json", flags.json, "Print the summary as one JSON object on stdout");
}

void add_threads_option(CLI::App* sub, std::string& threads) {
  sub->add_option("--threads", threads,
                  "Worker threads, 0 = all cores " +
                      default_note(std::to_string(nhnet::RunContext{}.threads)))
      ->type_name("N");
}

void add_precision_option(CLI::App* sub, std::string& precision) {
  sub->add_option("--precision", precision,
                  std::string("NH-Net arithmetic: auto | float32 | bfloat16. ") +
                      nhnet::kPrecisionHelp + " " +
                      default_note(nhnet::EstimateOptions{}.model.precision))
      ->type_name("P");
}

std::string parse_precision(const std::string& precision) {
  nhnet::check_precision(precision, "--precision");
  return precision;
}

void add_seed_option(CLI::App* sub, std::string& seed) {
  sub->add_option("--seed", seed,
                  "Seed of MFPS's random plane samples " +
                      default_note(std::to_string(nhnet::EstimateOptions{}.mfps.seed)))
      ->type_name("S");
}

}  // namespace nhcli
