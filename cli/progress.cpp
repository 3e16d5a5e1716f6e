// Progress bar and warnings on stderr; SIGINT/SIGTERM set a flag that cancels the core's work.
#include "progress.hpp"

#include "errors.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>

namespace nhcli {

// ---- signals ------------------------------------------------------------------------------------

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

// ---- stderr reporting ---------------------------------------------------------------------------

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
  std::snprintf(line, sizeof line, "\r\033[K%-12.40s [%s] %3d%% %6.1f s", name.c_str(), bar.c_str(),
                int(fraction * 100.0), elapsed());
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

}  // namespace nhcli
