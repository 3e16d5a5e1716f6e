// Internal: small order statistics shared by the stages.
#pragma once

#include <algorithm>
#include <vector>

namespace nhnet::detail {

/// The q-quantile (0..1, nearest rank below) of v; 0 for an empty vector. Takes v by value.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = size_t(std::clamp(q, 0.0, 1.0) * double(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

}  // namespace nhnet::detail
