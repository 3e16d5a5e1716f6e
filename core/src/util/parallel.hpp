// Internal: the one parallel-loop mechanism of the core (OpenMP) with progress and cancellation.
#pragma once

#include "nhnet/errors.hpp"
#include "nhnet/progress.hpp"

#include <omp.h>
#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <string>

namespace nhnet::detail {

/// Maps stage-local progress onto the overall [0, 1] range and owns the cancel flag.
class Progress {
 public:
  explicit Progress(const ProgressCallback& cb) : cb_(cb) {}

  /// Starts a stage that covers [begin, end] of the overall range. Throws Cancelled when the
  /// callback asks to stop.
  void stage(const std::string& name, double begin, double end) {
    name_ = name;
    begin_ = begin;
    end_ = end;
    report(0.0);
  }

  /// Reports progress within the current stage (0..1). Returns false once cancelled. Must be
  /// called from the calling thread only.
  bool report(double fraction) {
    if (cancelled_.load(std::memory_order_relaxed)) return false;
    if (!cb_) return true;
    const double f = begin_ + (end_ - begin_) * std::clamp(fraction, 0.0, 1.0);
    if (!cb_(f, name_)) cancelled_.store(true);
    return !cancelled_.load();
  }

  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  void throw_if_cancelled() const {
    if (cancelled()) throw Cancelled();
  }

 private:
  const ProgressCallback& cb_;
  std::string name_;
  double begin_ = 0, end_ = 1;
  std::atomic<bool> cancelled_{false};
};

/// `run` with its progress callback narrowed to [begin, end] of the overall range.
inline RunContext narrow(const RunContext& run, double begin, double end) {
  RunContext r;
  r.threads = run.threads;
  if (run.progress) {
    ProgressCallback cb = run.progress;
    r.progress = [cb, begin, end](double f, const std::string& stage) {
      return cb(begin + (end - begin) * f, stage);
    };
  }
  return r;
}

inline int thread_count(int requested) {
  return requested > 0 ? requested : std::max(1, omp_get_max_threads());
}

/// Starts the OpenMP thread pool for `threads` workers before any big allocation: libgomp keeps
/// its threads for later regions, so their stacks are reserved while memory is still free (a
/// pthread_create failure inside libgomp is fatal and cannot be caught).
inline void start_threads(int threads) {
  const int nt = thread_count(threads);
  if (nt <= 1) return;
#pragma omp parallel num_threads(nt)
  { (void)omp_get_thread_num(); }
}

/// Eigen 3.4's resize() frees the old buffer before allocating the new one and leaves the freed
/// pointer in place when the allocation throws (std::bad_alloc then ends in a double free when
/// the matrix is destroyed). Output matrices that may hold data are emptied first with this.
template <class Matrix>
void resize_fresh(Matrix& m, Eigen::Index rows, Eigen::Index cols) {
  if (m.size() != rows * cols) Matrix().swap(m);
  m.resize(rows, cols);
}

/// Runs fn(i) for i in [0, n) on `threads` threads (dynamic schedule). Thread 0 (the calling
/// thread) reports progress; a cancel request stops the remaining iterations and throws
/// Cancelled after the loop. An exception thrown by fn (std::bad_alloc, ...) cannot cross the
/// parallel region: the first one is kept, the remaining iterations are skipped and it is
/// rethrown on the calling thread after the loop.
template <class Fn>
void parallel_for(int64_t n, int threads, Progress* progress, Fn&& fn) {
  const int64_t chunk = 256;
  std::atomic<int64_t> done{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  const int nt = thread_count(threads);
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
  for (int64_t c = 0; c < (n + chunk - 1) / chunk; ++c) {
    if (failed.load(std::memory_order_relaxed) || (progress && progress->cancelled())) continue;
    try {
      const int64_t b = c * chunk, e = std::min(n, b + chunk);
      for (int64_t i = b; i < e; ++i) fn(i);
      const int64_t d = done.fetch_add(e - b) + (e - b);
      if (progress && omp_get_thread_num() == 0) progress->report(double(d) / double(n));
    } catch (...) {
#pragma omp critical(nhnet_parallel_for_error)
      {
        if (!error) error = std::current_exception();
      }
      failed.store(true);
    }
  }
  if (error) std::rethrow_exception(error);
  if (progress) {
    progress->throw_if_cancelled();
    progress->report(1.0);
    progress->throw_if_cancelled();
  }
}

}  // namespace nhnet::detail
