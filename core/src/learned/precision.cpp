// The network's arithmetic, ModelOptions::precision (nhnet_model.hpp): which values are valid.
// Built with or without libtorch.
#include "nhnet/learned/nhnet_model.hpp"

#include <algorithm>

namespace nhnet {

bool valid_precision(const std::string& precision) {
  return std::any_of(kPrecisions.begin(), kPrecisions.end(),
                     [&](const char* p) { return precision == p; });
}

}  // namespace nhnet
