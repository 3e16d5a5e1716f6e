// NH-Net inference in a core built without libtorch: every entry point says so.
#include "nhnet/learned/nhnet_model.hpp"

#include "nhnet/errors.hpp"

namespace nhnet {

namespace {
[[noreturn]] void unavailable() {
  throw InvalidOptions(
      "this nhnet was built without libtorch, so --method nhnet is unavailable; install "
      "libtorch-dev and reconfigure (cmake -S . -B build), or use --method mfps");
}
}  // namespace

bool nhnet_available() { return false; }
std::string default_model_path() { return {}; }
struct NhNetModel::Impl {};
NhNetModel::NhNetModel(const std::string&, const std::string&, int, const std::string&) {
  unavailable();
}
NhNetModel::~NhNetModel() = default;
NhNetModel::NhNetModel(NhNetModel&&) noexcept = default;
NhNetModel& NhNetModel::operator=(NhNetModel&&) noexcept = default;
const std::string& NhNetModel::device() const { unavailable(); }
const std::string& NhNetModel::precision() const { unavailable(); }
const std::string& NhNetModel::metadata() const { unavailable(); }
int NhNetModel::descriptor_version() const { unavailable(); }
Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> NhNetModel::infer(
    const DescriptorMatrix&, int, const RunContext&) const {
  unavailable();
}

}  // namespace nhnet
