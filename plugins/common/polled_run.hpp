// Shared by the MeshLab and CloudCompare plugins: runs a core call on a worker thread while the
// host's thread (the GUI thread in MeshLab and CloudCompare) polls its progress every few
// milliseconds, so the host stays responsive on clouds of tens of millions of points and can
// cancel. Header-only, standard library and the core's ProgressCallback only.
#pragma once

#include "nhnet/progress.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <functional>
#include <future>
#include <mutex>
#include <string>

namespace nhplugin {

/// Called on the host's thread with the latest fraction done and stage; false = cancel.
using Poll = std::function<bool(double fraction, const std::string& stage)>;

/// How often the host's thread polls: short enough for a repainted dialog and a prompt Cancel.
constexpr std::chrono::milliseconds kPollPeriod{30};

/// Runs `work` on a worker thread with a progress callback that records the fraction and stage
/// and returns false once `poll` has returned false (the core then throws nhnet::Cancelled);
/// calls `poll` on this thread every kPollPeriod until `work` ends. Rethrows what `work` threw.
inline void run_polled(const std::function<void(const nhnet::ProgressCallback&)>& work,
                       const Poll& poll) {
  std::atomic<bool> cancel{false};
  std::mutex mutex;
  double fraction = 0;
  std::string stage;
  const nhnet::ProgressCallback cb = [&](double f, const std::string& s) {
    std::lock_guard<std::mutex> lock(mutex);
    fraction = std::clamp(f, 0.0, 1.0);
    stage = s;
    return !cancel.load();
  };
  std::future<void> done = std::async(std::launch::async, [&] { work(cb); });
  while (done.wait_for(kPollPeriod) != std::future_status::ready) {
    double f;
    std::string s;
    {
      std::lock_guard<std::mutex> lock(mutex);
      f = fraction;
      s = stage;
    }
    if (!cancel.load() && !poll(f, s)) cancel = true;
  }
  done.get();
}

/// Test hook of the plugins' cancel path (tests/meshlab, tests/cloudcompare): when the
/// environment variable NHNET_PLUGIN_CANCEL_AT holds a fraction in (0, 1], a run is cancelled
/// as if the user pressed Cancel once its progress reaches it. Unset (every real use): never.
inline double test_cancel_at() {
  const char* v = std::getenv("NHNET_PLUGIN_CANCEL_AT");
  if (v == nullptr || *v == '\0') return 2.0;  // beyond any fraction: never
  char* end = nullptr;
  const double f = std::strtod(v, &end);
  return (end != v && f > 0 && f <= 1) ? f : 2.0;
}

}  // namespace nhplugin
