// The default method of every front end (estimate.hpp): NH-Net when it can run, else MFPS.
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <fstream>
#include <string>

namespace nhnet {

Method default_method(std::string* fallback_why) {
  std::string why;
  if (!nhnet_available()) {
    why = "this build has no libtorch";
  } else {
    const std::string model = default_model_path();
    if (model.empty() || !std::ifstream(model).good())
      why = "the NH-Net model " + (model.empty() ? std::string("file") : model) + " is missing";
  }
  if (fallback_why) *fallback_why = why;
  return why.empty() ? Method::NhNet : Method::Mfps;
}

}  // namespace nhnet
