// The network's arithmetic, ModelOptions::precision (nhnet_model.hpp): which values are valid and
// whether the CPU has what "auto" needs. Built with or without libtorch.
#include "nhnet/learned/nhnet_model.hpp"

#include "nhnet/errors.hpp"

#include <algorithm>
#include <cstddef>

namespace nhnet {

bool cpu_has_bfloat16() {
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512bf16");
#else
  return false;
#endif
}

bool valid_precision(const std::string& precision) {
  return std::any_of(kPrecisions.begin(), kPrecisions.end(),
                     [&](const char* p) { return precision == p; });
}

void check_precision(const std::string& precision, const std::string& what) {
  if (valid_precision(precision)) return;
  std::string list;
  for (size_t i = 0; i < kPrecisions.size(); ++i)
    list += std::string(i == 0 ? "" : i + 1 == kPrecisions.size() ? " or " : ", ") + kPrecisions[i];
  throw InvalidOptions(what + " must be " + list + ", got '" + precision + "'");
}

std::string network_phrase(const std::string& device, const std::string& precision) {
  return device.empty() ? std::string() : " on " + device + " in " + precision;
}

}  // namespace nhnet
