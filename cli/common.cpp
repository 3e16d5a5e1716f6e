// Shared helpers of nhnet-cli: strict parameter parsing, signals, progress bar, JSON strings.
#include "common.hpp"

#include "nhnet/errors.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>

namespace nhcli {

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

nhnet::ProgressCallback Reporter::callback() {
  return [this](double fraction, const std::string& name) {
    draw(fraction, name, false);
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

}  // namespace nhcli
