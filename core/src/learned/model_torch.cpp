// NH-Net inference through libtorch (TorchScript); see nhnet_model.hpp. The only file of the
// core that includes libtorch.
#include "nhnet/learned/nhnet_model.hpp"

#include "nhnet/errors.hpp"

#include <ATen/Parallel.h>
#include <torch/cuda.h>
#include <torch/script.h>

#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#ifndef NHNET_MODEL_INSTALL_PATH
#define NHNET_MODEL_INSTALL_PATH ""
#endif
#ifndef NHNET_MODEL_SOURCE_PATH
#define NHNET_MODEL_SOURCE_PATH ""
#endif

namespace nhnet {

namespace {

bool file_exists(const std::string& p) { return !p.empty() && std::ifstream(p).good(); }

/// The first line of a libtorch error (its message), without the C++ stack trace after it.
std::string torch_message(const std::exception& e) {
  std::string m = e.what();
  for (const char* cut : {"\n", " Exception raised from "})
    if (const size_t p = m.find(cut); p != std::string::npos) m.resize(p);
  return m.substr(0, 300);
}

/// The raw JSON text of `key`'s value in a flat-ish JSON object (numbers, strings, arrays of
/// numbers), as json.dumps writes it; empty if absent.
std::string json_value(const std::string& json, const std::string& key) {
  const std::string k = "\"" + key + "\":";
  size_t p = json.find(k);
  if (p == std::string::npos) return {};
  p += k.size();
  while (p < json.size() && json[p] == ' ') ++p;
  size_t e = p;
  if (p < json.size() && json[p] == '[') {
    e = json.find(']', p);
    return e == std::string::npos ? std::string() : json.substr(p, e - p + 1);
  }
  if (p < json.size() && json[p] == '"') {
    e = json.find('"', p + 1);
    return e == std::string::npos ? std::string() : json.substr(p + 1, e - p - 1);
  }
  while (e < json.size() && json[e] != ',' && json[e] != '}') ++e;
  return json.substr(p, e - p);
}

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  std::string t = text;
  for (char& c : t)
    if (c == '[' || c == ']' || c == ',') c = ' ';
  std::istringstream in(t);
  double v;
  while (in >> v) out.push_back(v);
  return out;
}

void check_numbers(const std::string& meta, const std::string& key, const std::vector<double>& want,
                   const std::string& path) {
  const std::vector<double> got = numbers(json_value(meta, key));
  bool same = got.size() == want.size();
  for (size_t i = 0; same && i < got.size(); ++i) same = std::abs(got[i] - want[i]) < 1e-9;
  if (!same) {
    std::ostringstream w;
    for (double v : want) w << v << ' ';
    throw ModelError("model " + path + " was trained with " + key + " = " + json_value(meta, key) +
                     " but this nhnet computes " + w.str() +
                     "; retrain it (nhnet-train) or use a model made for this version");
  }
}

/// The model's descriptor version, checked against those this core computes.
int descriptor_version_of(const std::string& meta, const std::string& path) {
  const std::vector<double> got = numbers(json_value(meta, "descriptor_version"));
  const bool known = got.size() == 1 && got[0] == std::floor(got[0]) &&
                     got[0] >= kOldestDescriptorVersion && got[0] <= kDescriptorVersion;
  if (!known)
    throw ModelError("model " + path + " was trained with descriptor_version = " +
                     json_value(meta, "descriptor_version") + " but this nhnet computes " +
                     std::to_string(kOldestDescriptorVersion) + " to " +
                     std::to_string(kDescriptorVersion) +
                     "; retrain it (nhnet-train) or use a model made for this version");
  return int(got[0]);
}

/// Checks the model's metadata against what this core computes; returns its descriptor version.
int check_metadata(const std::string& meta, const std::string& path) {
  if (json_value(meta, "format") != "nhnet-model")
    throw ModelError("model " + path +
                     " has no nhnet metadata (nhnet.json); export it with "
                     "nhnet-export");
  const int version = descriptor_version_of(meta, path);
  const DescriptorOptions d = descriptor_options(version);
  check_numbers(meta, "descriptor_size", {double(descriptor_size(d))}, path);
  check_numbers(meta, "patch_size", {double(d.map.size)}, path);
  check_numbers(meta, "sigma_s", d.filter.sigma_s, path);
  check_numbers(meta, "sigma_r", d.filter.sigma_r, path);
  check_numbers(meta, "neighborhood_factor", {d.neighborhood_factor}, path);
  if (json_value(meta, "height_normalisation") != kHeightNormalisation)
    throw ModelError("model " + path + " expects height normalisation '" +
                     json_value(meta, "height_normalisation") + "' but this nhnet computes '" +
                     kHeightNormalisation + "'; retrain it (nhnet-train)");
  return version;
}

}  // namespace

bool nhnet_available() { return true; }

std::string default_model_path() {
  if (const char* env = std::getenv("NHNET_MODEL"); env && *env) return env;
  if (file_exists(NHNET_MODEL_INSTALL_PATH)) return NHNET_MODEL_INSTALL_PATH;
  return NHNET_MODEL_SOURCE_PATH;
}

struct NhNetModel::Impl {
  torch::jit::script::Module module;
  torch::Device dev{torch::kCPU};
  std::string device;
  std::string precision;
  torch::ScalarType dtype = torch::kFloat32;  // of the descriptors fed in (to_low_precision)
  std::string meta;
  int descriptor_version = kDescriptorVersion;
};

namespace {

/// Frozen (weights inlined as constants, batch norms folded into the layers before them) and,
/// on the CPU, optimised for inference (oneDNN convolutions): 3.3x the points per second of
/// the scripted module on 2 cores, outputs equal to 1e-6
/// (docs/design/decisions.md#nh-net-inference-frozen-and-optimised-on-load). `steps` 2 = both,
/// 1 = frozen only, 0 = as loaded. Throws what the passes throw.
torch::jit::Module prepared(const torch::jit::Module& loaded, bool cpu, int steps) {
  torch::jit::Module m = loaded.clone();
  if (steps >= 1) m = torch::jit::freeze(m);
  if (steps >= 2 && cpu) m = torch::jit::optimize_for_inference(m);
  return m;
}

/// The names in a JSON array of strings as json.dumps writes it (["a", "b"]); empty if none.
std::vector<std::string> names(const std::string& array) {
  std::vector<std::string> out;
  for (size_t p = array.find('"'); p != std::string::npos; p = array.find('"', p + 1)) {
    const size_t e = array.find('"', p + 1);
    if (e == std::string::npos) break;
    out.push_back(array.substr(p + 1, e - p - 1));
    p = e;
  }
  return out;
}

/// Casts the network to `dtype` for ModelOptions::precision. A model whose metadata names its
/// "bfloat16_modules" (`parts`; nhnet-export since v7's re-export) casts only those, and its
/// forward feeds them in their dtype and takes their output back to float32, so the descriptors
/// go in as float32 (`dtype` becomes float32 here); an older model casts whole, its input with it.
void to_low_precision(torch::jit::Module& module, const std::vector<std::string>& parts,
                      torch::ScalarType& dtype, const std::string& path) {
  if (parts.empty()) {
    module.to(dtype);
    return;
  }
  for (const std::string& name : parts) {
    if (!module.hasattr(name) || !module.attr(name).isModule())
      throw ModelError("model " + path + " names '" + name +
                       "' among its bfloat16_modules but has no such layer; export it again "
                       "with nhnet-export");
    module.attr(name).toModule().to(dtype);
  }
  dtype = torch::kFloat32;
}

/// ModelOptions::precision for this device and model: "auto" is bfloat16 on a CPU with
/// AVX512-BF16 for a model that names its bfloat16_modules (`named`; where bfloat16 is both
/// faster and as accurate), else float32; the others as they are.
std::string resolved_precision(const std::string& precision, const std::string& device,
                               bool named) {
  if (precision != "auto") return precision;
  return device == "cpu" && named && cpu_has_bfloat16() ? "bfloat16" : "float32";
}

/// A test forward pass on two zero descriptors: a model that loads but is not a B x D -> B x 3
/// network (or breaks on this device or in this precision) is refused here, before any input
/// is read.
void check_forward(torch::jit::Module& module, torch::Device dev, torch::ScalarType dtype,
                   const std::string& path) {
  const int64_t dsize = descriptor_size(DescriptorOptions{});
  try {
    torch::InferenceMode guard;
    const torch::Tensor y = module.forward({torch::zeros({2, dsize}, dtype).to(dev)}).toTensor();
    if (y.dim() != 2 || y.size(0) != 2 || y.size(1) != 3)
      throw ModelError("model " + path + " maps 2 x " + std::to_string(dsize) +
                       " descriptors to a tensor of shape " + c10::str(y.sizes()) +
                       ", not 2 x 3; export it with nhnet-export");
  } catch (const ModelError&) {
    throw;
  } catch (const std::exception& e) {
    throw ModelError("model " + path + " fails on " + std::to_string(dsize) +
                     "-value descriptors: " + torch_message(e));
  }
}

}  // namespace

NhNetModel::NhNetModel(const std::string& path, const std::string& device, int threads,
                       const std::string& precision)
    : impl_(std::make_unique<Impl>()) {
  if (device != "auto" && device != "cpu" && device != "cuda")
    throw InvalidOptions("device must be auto, cpu or cuda, got '" + device + "'");
  check_precision(precision, "precision");
  if (threads < 0) throw InvalidOptions("threads must be >= 0");
  const bool cuda = torch::cuda::is_available();
  if (device == "cuda" && !cuda)
    throw DeviceUnavailable(
        "--device cuda: the linked libtorch has no CUDA support or no GPU is "
        "visible; use --device cpu (or auto)");
  impl_->device = (device == "cuda" || (device == "auto" && cuda)) ? "cuda" : "cpu";
  impl_->dev = impl_->device == "cuda" ? torch::Device(torch::kCUDA) : torch::Device(torch::kCPU);
  if (!file_exists(path))
    throw ModelError("no NH-Net model at '" + path +
                     "': pass --model PATH (train one with "
                     "nhnet-train, see training/README.md) or use --method mfps");
  torch::jit::ExtraFilesMap extra{{"nhnet.json", ""}};
  try {
    impl_->module = torch::jit::load(path, impl_->dev, extra);
  } catch (const std::exception& e) {
    throw ModelError("cannot load NH-Net model '" + path +
                     "' (truncated, corrupt or not a "
                     "TorchScript archive): " +
                     torch_message(e));
  }
  impl_->meta = extra["nhnet.json"];
  impl_->descriptor_version = check_metadata(impl_->meta, path);
  impl_->module.eval();
  const std::vector<std::string> low = names(json_value(impl_->meta, "bfloat16_modules"));
  impl_->precision = resolved_precision(precision, impl_->device, !low.empty());
  impl_->dtype = impl_->precision == "bfloat16" ? torch::kBFloat16 : torch::kFloat32;
  if (impl_->dtype != torch::kFloat32) to_low_precision(impl_->module, low, impl_->dtype, path);
  at::set_num_threads(threads > 0 ? threads : std::max(1, omp_get_max_threads()));
  // The most prepared module that runs: a model the passes cannot handle runs as it was loaded,
  // and oneDNN's optimised convolutions refuse bfloat16 on CPUs without AVX-512, where the
  // frozen module runs on ATen's own kernels (slower). The last failure is the error.
  const torch::jit::Module loaded = impl_->module;
  for (int steps = 2; steps >= 0; --steps) {
    try {
      impl_->module = prepared(loaded, impl_->device == "cpu", steps);
      check_forward(impl_->module, impl_->dev, impl_->dtype, path);
      return;
    } catch (const std::exception&) {
      if (steps == 0) throw;
    }
  }
}

NhNetModel::~NhNetModel() = default;
NhNetModel::NhNetModel(NhNetModel&&) noexcept = default;
NhNetModel& NhNetModel::operator=(NhNetModel&&) noexcept = default;
const std::string& NhNetModel::device() const { return impl_->device; }
const std::string& NhNetModel::precision() const { return impl_->precision; }
const std::string& NhNetModel::metadata() const { return impl_->meta; }
int NhNetModel::descriptor_version() const { return impl_->descriptor_version; }

Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> NhNetModel::infer(
    const DescriptorMatrix& features, int batch, const RunContext& run) const {
  if (batch < 1) throw InvalidOptions("batch must be >= 1");
  const Eigen::Index n = features.rows(), d = features.cols();
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> out;
  out.setConstant(n, 3, std::numeric_limits<float>::quiet_NaN());
  std::vector<Eigen::Index> rows;
  rows.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i)
    if (features.row(i).allFinite()) rows.push_back(i);
  torch::InferenceMode guard;
  std::vector<float> buf;
  // The stage starts here (the caller can time the network apart from what came before).
  if (run.progress && !run.progress(0.0, "nhnet")) throw Cancelled();
  for (size_t b = 0; b < rows.size(); b += size_t(batch)) {
    const size_t e = std::min(rows.size(), b + size_t(batch));
    // Consecutive rows (every row finite, the usual case) go in where they are (an exported
    // model reads its input and never writes it); others are gathered into one block first.
    const float* first = features.row(rows[b]).data();
    if (rows[e - 1] - rows[b] != Eigen::Index(e - 1 - b)) {
      buf.resize((e - b) * size_t(d));
      for (size_t r = b; r < e; ++r)
        std::copy(features.row(rows[r]).data(), features.row(rows[r]).data() + d,
                  buf.data() + (r - b) * size_t(d));
      first = buf.data();
    }
    torch::Tensor x =
        torch::from_blob(const_cast<float*>(first), {int64_t(e - b), int64_t(d)}, torch::kFloat32)
            .to(impl_->dev, impl_->dtype);
    torch::Tensor y =
        impl_->module.forward({x}).toTensor().to(torch::kCPU, torch::kFloat32).contiguous();
    if (y.dim() != 2 || y.size(0) != int64_t(e - b) || y.size(1) != 3)
      throw ModelError("the NH-Net model returned a tensor of the wrong shape (expected B x 3)");
    const float* p = y.data_ptr<float>();
    for (size_t r = b; r < e; ++r)
      for (int c = 0; c < 3; ++c) out(rows[r], c) = p[(r - b) * 3 + size_t(c)];
    if (run.progress && !run.progress(double(e) / double(rows.size()), "nhnet")) throw Cancelled();
  }
  return out;
}

}  // namespace nhnet
