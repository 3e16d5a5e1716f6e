// Shared helpers of nhnet-cli: strict parameter parsing, signals, progress bar, JSON strings.
#include "common.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/nhnet_model.hpp"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace nhcli {

int classify_current_exception(std::string& message) {
  try {
    throw;
  } catch (const nhnet::Cancelled&) {
    const int sig = interrupted();
    message = std::string("interrupted") +
              (sig == SIGTERM ? " (SIGTERM)" : sig == SIGINT ? " (SIGINT)" : "") +
              "; no output written";
    return sig == SIGTERM ? kTerminated : kInterrupted;
  } catch (const nhnet::DeviceUnavailable& e) {
    message = e.what();
    return kDevice;
  } catch (const nhnet::InvalidOptions& e) {
    message = e.what();
    return kUsage;
  } catch (const nhnet::ModelError& e) {
    message = e.what();
    return kModel;
  } catch (const nhnet::InputError& e) {
    message = e.what();
    return kInput;
  } catch (const nhnet::UnprocessableInput& e) {
    message = e.what();
    return kUnprocessable;
  } catch (const nhnet::OutputError& e) {
    message = e.what();
    return kOutput;
  } catch (const std::bad_alloc& e) {
    message = dynamic_cast<const OutOfMemory*>(&e) != nullptr ? e.what() : "out of memory";
    return kMemory;
  } catch (const std::exception& e) {
    message = std::string("internal error: ") + e.what();
    return kFailure;
  } catch (...) {
    message = "internal error: unknown exception";
    return kFailure;
  }
}

// ---- parameters --------------------------------------------------------------------------------

namespace {

std::string quoted(const std::string& s) { return "'" + one_line(s) + "'"; }

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
  size_t begin = 0;
  while (true) {
    const size_t comma = text.find(',', begin);
    const std::string item = text.substr(begin, comma == std::string::npos ? std::string::npos
                                                                           : comma - begin);
    int value = 0;
    const char* last = item.data() + item.size();
    const auto [ptr, ec] = std::from_chars(item.data(), last, value);
    if (item.empty() || ec != std::errc() || ptr != last || value < 3)
      throw nhnet::InvalidOptions("--scales must be 'auto' or a comma-separated list of integers "
                                  ">= 3 (e.g. 50,100,150), got " + quoted(text));
    scales.push_back(value);
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return scales;
}

double parse_double(const std::string& option, const std::string& text, double above) {
  double value = 0;
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), last, value);
  if (text.empty() || ec != std::errc() || ptr != last || !std::isfinite(value) || !(value > above)) {
    char bound[32];
    std::snprintf(bound, sizeof bound, "%g", above);
    throw nhnet::InvalidOptions(option + " must be a number > " + bound + ", got " + quoted(text));
  }
  return value;
}

nhnet::OrientOptions parse_orient(const std::string& text) {
  const std::string usage =
      "--orient must be keep, none, mst, mst:K (K >= 2) or viewpoint X Y Z, got " + quoted(text);
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
    std::vector<std::string> xyz;
    for (size_t b = 0;;) {
      const size_t c = values.find(',', b);
      xyz.push_back(values.substr(b, c == std::string::npos ? std::string::npos : c - b));
      if (c == std::string::npos) break;
      b = c + 1;
    }
    if (colon == std::string::npos || xyz.size() != 3)
      throw nhnet::InvalidOptions("--orient viewpoint needs 3 coordinates X Y Z, got " +
                                  quoted(text));
    for (int d = 0; d < 3; ++d)
      opt.viewpoint[d] = parse_double("--orient viewpoint " + std::string(1, char('X' + d)),
                                      xyz[size_t(d)], -HUGE_VAL);
  } else if (colon != std::string::npos) {
    throw nhnet::InvalidOptions(usage);
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

// ---- shared arguments ----------------------------------------------------------------------------

void add_in_out(CLI::App* sub, std::string& in, std::string& out) {
  sub->add_option("IN", in, "Input cloud (.ply, .pcd, .xyz/.xyzn/.txt; content is sniffed)")
      ->required();
  sub->add_option("OUT", out,
                  "Output cloud; the format follows the extension (.ply, .pcd, .xyz/.xyzn/.txt)")
      ->required();
}

void add_output_flags(CLI::App* sub, bool& ascii, bool& overwrite, bool& quiet, bool& json) {
  sub->add_flag("--ascii", ascii, "Write PLY/PCD as ascii instead of binary");
  sub->add_flag("--overwrite", overwrite, "Replace OUT if it exists (never the input)");
  sub->add_flag("-q,--quiet", quiet,
                "No progress bar and no summary line (warnings and errors still go to stderr)");
  sub->add_flag("--json", json, "Print the summary as one JSON object on stdout");
}

// ---- files ---------------------------------------------------------------------------------------

std::string default_method(std::string& why) {
  if (!nhnet::nhnet_available()) {
    why = "this build has no libtorch";
    return "mfps";
  }
  const std::string model = nhnet::default_model_path();
  if (model.empty() || !std::ifstream(model).good()) {
    why = "the NH-Net model " + (model.empty() ? std::string("file") : model) + " is missing";
    return "mfps";
  }
  return "nhnet";
}

namespace fs = std::filesystem;

/// Output path checks (exit 6) done before reading anything.
void check_output(const std::string& in, const std::string& out, bool overwrite) {
  std::error_code ec;
  const fs::path out_path(out), in_path(in);
  const fs::file_status st = fs::status(out_path, ec);
  if (fs::exists(st)) {
    if (fs::is_directory(st)) throw nhnet::OutputError(out + ": is a directory");
    std::error_code ec2;
    if (fs::exists(in_path, ec2) && fs::equivalent(in_path, out_path, ec2) && !ec2)
      throw nhnet::OutputError("refusing to overwrite the input " + in +
                               " (choose another output path)");
    if (!overwrite)
      throw nhnet::OutputError(out + " already exists (use --overwrite to replace it)");
  }
  fs::path dir = out_path.parent_path();
  if (dir.empty()) dir = ".";
  const fs::file_status dst = fs::status(dir, ec);
  if (!fs::exists(dst))
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() +
                             " does not exist");
  if (!fs::is_directory(dst))
    throw nhnet::OutputError("cannot write " + out + ": " + dir.string() + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() + ": " +
                             std::strerror(errno));
}

void check_output_format(const std::string& out) {
  if (nhnet::format_from_extension(out) == nhnet::FileFormat::Auto)
    throw nhnet::InvalidOptions("cannot tell the output format from the extension of " + out +
                                " (use .ply, .pcd, .xyz, .xyzn or .txt)");
}

// ---- signals -------------------------------------------------------------------------------------

namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) { g_signal = sig; }

void install(int sig, bool keep_ignored) {
  struct sigaction old {};
  if (sigaction(sig, nullptr, &old) != 0) return;
  if (keep_ignored && old.sa_handler == SIG_IGN) return;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  // SA_RESETHAND: the first signal asks the core to stop cleanly, a second one kills.
  sa.sa_flags = SA_RESTART | SA_RESETHAND;
  sigaction(sig, &sa, nullptr);
}

}  // namespace

void install_signal_handlers() {
  install(SIGINT, /*keep_ignored=*/true);
  install(SIGTERM, /*keep_ignored=*/false);
}

int interrupted() { return int(g_signal); }

void throw_if_interrupted() {
  if (g_signal != 0) throw nhnet::Cancelled();
}

// ---- stderr reporting ----------------------------------------------------------------------------

namespace {

constexpr auto kRedrawInterval = std::chrono::milliseconds(100);
constexpr int kBarWidth = 24;

}  // namespace

Reporter::Reporter(bool quiet)
    : quiet_(quiet),
      bar_(!quiet && ::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - kRedrawInterval) {}

Reporter::~Reporter() { clear(); }

double Reporter::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Reporter::stage(const std::string& name, double fraction) { draw(fraction, name, true); }

nhnet::ProgressCallback Reporter::callback(double begin, double end) {
  return [this, begin, end](double fraction, const std::string& name) {
    draw(begin + (end - begin) * fraction, name, false);
    return interrupted() == 0;
  };
}

void Reporter::draw(double fraction, const std::string& name, bool force) {
  if (!bar_) return;
  const auto now = std::chrono::steady_clock::now();
  // At most ~10 redraws a second within a stage; a new stage shows sooner (but not in bursts).
  const auto since = now - last_draw_;
  if (name == last_stage_ ? (!force && since < kRedrawInterval) : since < kRedrawInterval / 4)
    return;
  last_draw_ = now;
  last_stage_ = name;
  if (!std::isfinite(fraction)) fraction = 0;
  fraction = std::clamp(fraction, 0.0, 1.0);
  const int filled = int(fraction * kBarWidth + 0.5);
  std::string bar(size_t(filled), '#');
  bar.resize(size_t(kBarWidth), '.');
  char line[256];
  std::snprintf(line, sizeof line, "\r\033[K%-12.40s [%s] %3d%% %6.1f s", name.c_str(),
                bar.c_str(), int(fraction * 100.0), elapsed());
  std::fputs(line, stderr);
  std::fflush(stderr);
  shown_ = true;
}

void Reporter::clear() {
  if (!shown_) return;
  std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  shown_ = false;
  last_stage_.clear();
}

void Reporter::warn(const std::string& message) {
  clear();
  std::cerr << "nhnet-cli: warning: " << one_line(message) << std::endl;
}

// ---- orientation ---------------------------------------------------------------------------------

void warn_unoriented(Reporter& rep, const nhnet::OrientOptions& opt, const nhnet::OrientResult& r) {
  if (r.unoriented_components > 0)
    rep.warn("--orient mst: " + std::to_string(r.unoriented_components) + " of " +
             std::to_string(r.components) + " connected parts could not be oriented; " +
             std::to_string(r.unoriented) + " normals keep an arbitrary sign");
  else if (r.unoriented > 0)
    rep.warn("--orient " + std::string(nhnet::to_string(opt.mode)) + ": " +
             std::to_string(r.unoriented) + " normals could not be oriented (" +
             (opt.mode == nhnet::OrientMode::Keep ? "the input normal is missing or perpendicular"
                                                  : "perpendicular to the line of sight") +
             "); their sign is arbitrary");
}

std::string orient_summary(const nhnet::OrientOptions& opt, const nhnet::OrientResult& r) {
  std::string s = nhnet::to_string(opt.mode);
  if (opt.mode == nhnet::OrientMode::None) return s;
  s += " (";
  if (opt.mode == nhnet::OrientMode::Mst)
    s += std::to_string(r.components) + (r.components == 1 ? " part, " : " parts, ") +
         std::to_string(r.completed) + " completed, ";
  if (opt.mode != nhnet::OrientMode::Keep || r.unoriented > 0)
    s += std::to_string(r.unoriented) + " unoriented, ";
  s += std::to_string(r.flipped) + " flipped";
  if (opt.mode == nhnet::OrientMode::Mst && opt.inside_outside)
    s += r.voxel > 0 ? ", " + std::to_string(r.inside_outside_votes) + " sided by the flood fill"
                     : ", open: the tree alone";
  return s + ")";
}

std::string orient_json(const nhnet::OrientOptions& opt, const nhnet::OrientResult& r) {
  std::string s = "\"orient\": " + json_string(nhnet::to_string(opt.mode)) +
                  ", \"flipped\": " + std::to_string(r.flipped) +
                  ", \"unoriented\": " + std::to_string(r.unoriented) +
                  ", \"components\": " + std::to_string(r.components) +
                  ", \"unoriented_components\": " + std::to_string(r.unoriented_components) +
                  ", \"completed\": " + std::to_string(r.completed);
  if (opt.mode == nhnet::OrientMode::Mst)
    s += ", \"orient_k\": " + std::to_string(opt.k) +
         ", \"inside_outside_votes\": " + std::to_string(r.inside_outside_votes) +
         ", \"voxel\": " + json_number(r.voxel, 17);
  if (opt.mode == nhnet::OrientMode::Viewpoint)
    s += ", \"viewpoint\": [" + json_number(opt.viewpoint[0], 17) + ", " +
         json_number(opt.viewpoint[1], 17) + ", " + json_number(opt.viewpoint[2], 17) + "]";
  return s;
}

// ---- output helpers ------------------------------------------------------------------------------

std::string one_line(std::string text) {
  std::replace_if(text.begin(), text.end(), [](char c) { return c == '\n' || c == '\r' || c == '\t'; },
                  ' ');
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(c));
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

std::string json_number(double value, int precision) {
  if (!std::isfinite(value)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", precision, value);
  return buf;
}

nhnet::Cloud read_input(Reporter& rep, const std::string& in, std::vector<std::string>& warnings) {
  rep.stage("reading");
  nhnet::Cloud cloud = nhnet::read_cloud(in, {}, &warnings);
  for (const auto& w : warnings) rep.warn(w);
  return cloud;
}

void write_output(Reporter& rep, const std::string& out, const nhnet::Cloud& cloud, bool ascii) {
  nhnet::WriteOptions wopt;
  wopt.ascii = ascii;
  rep.stage("writing", 1.0);
  nhnet::write_cloud(out, cloud, wopt);
  rep.clear();
}

}  // namespace nhcli
