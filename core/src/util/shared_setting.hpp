// Internal: a process-wide setting that concurrent users share (pipeline/refine.cpp's glibc malloc
// settings). Not a paper stage.
#pragma once

#include <functional>
#include <mutex>
#include <utility>

namespace nhnet::detail {

/// A setting held by counted users: the first Hold applies it, the last one to go restores it,
/// both under one mutex, so one user's end never undoes the setting while another still runs.
class SharedSetting {
 public:
  SharedSetting(std::function<void()> apply, std::function<void()> restore)
      : apply_(std::move(apply)), restore_(std::move(restore)) {}

  /// One user of the setting, for its lifetime.
  class Hold {
   public:
    explicit Hold(SharedSetting& s) : s_(s) {
      const std::lock_guard<std::mutex> lock(s_.mutex_);
      if (s_.holders_++ == 0) s_.apply_();
    }
    ~Hold() {
      const std::lock_guard<std::mutex> lock(s_.mutex_);
      if (--s_.holders_ == 0) s_.restore_();
    }
    Hold(const Hold&) = delete;
    Hold& operator=(const Hold&) = delete;

   private:
    SharedSetting& s_;
  };

 private:
  std::function<void()> apply_, restore_;
  std::mutex mutex_;
  int holders_ = 0;
};

}  // namespace nhnet::detail
