// NH-Net inference (paper Sec. 5.2): a trained TorchScript model (training/, models/) applied to
// the descriptors of descriptors.hpp. libtorch stays inside core/src/learned/model_torch.cpp
// (PImpl); a core built without libtorch reports that through nhnet_available() and throws
// InvalidOptions from the calls below.
#pragma once

#include "nhnet/learned/descriptors.hpp"
#include "nhnet/progress.hpp"

#include <array>
#include <memory>
#include <string>

namespace nhnet {

/// True when this build links libtorch (the nhnet method is usable).
bool nhnet_available();

/// The shipped model's path: $NHNET_MODEL if set, else the installed copy
/// (<prefix>/share/nhnet/models/nhnet.pt) if it exists, else the source tree's models/nhnet.pt.
std::string default_model_path();

class NhNetModel;

/// Where the network runs under the candidate mix (ModelOptions::refine).
enum class Refine {
  All,    ///< every point
  Moved,  ///< only where MFPS moved the PCA normal, near features (2-4x less network time)
  Auto,   ///< All on a noisy cloud, Moved on a clean one (ModelOptions::auto_noise_ratio)
};

/// The values ModelOptions::precision takes, the default first: the one list the core, the CLI
/// and the Python bindings (nhnet.PRECISIONS) check against.
inline constexpr std::array<const char*, 3> kPrecisions = {"auto", "float32", "bfloat16"};

/// What each of kPrecisions does, in one sentence a value: the help of every front end's
/// precision setting (nhnet-cli --precision, the MeshLab parameter, the CloudCompare list).
inline constexpr const char* kPrecisionHelp =
    "auto: bfloat16 where the CPU has AVX512-BF16 and the model supports it, else float32; "
    "float32: the same normals on every machine; bfloat16: ~1.8x the network's speed on CPUs "
    "with AVX512-BF16 or AMX, slower on others, normals within ~0.01 degree";

/// Whether `precision` is one of kPrecisions.
bool valid_precision(const std::string& precision);

/// Throws InvalidOptions "<what> must be auto, float32 or bfloat16, got '<precision>'" (the list
/// from kPrecisions) unless valid_precision(precision); `what` names the setting to the user.
void check_precision(const std::string& precision, const std::string& what);

/// " on <device> in <precision>" (e.g. " on cpu in bfloat16") when a network ran (`device` not
/// empty: EstimateResult::device_used), else "": how nhnet-cli's summary and the plugins' logs
/// name where and in which arithmetic the network ran.
std::string network_phrase(const std::string& device, const std::string& precision);

/// Whether this CPU has AVX512-BF16, the dot products oneDNN's bfloat16 kernels run on (every
/// CPU with AMX has them); elsewhere bfloat16 runs slower than float32.
bool cpu_has_bfloat16();

/// Which model the learned stage runs, where, and how many points at a time.
struct ModelOptions {
  /// Model file (TorchScript from nhnet-export); empty = the shipped model (default_model_path()).
  std::string path;
  /// Device: "auto" (CUDA if available, else CPU), "cpu" or "cuda".
  std::string device = "auto";
  /// The network's arithmetic (kPrecisions): "float32"; "bfloat16" (the layers the model's
  /// metadata names, nearly all its multiply-adds: 1.8x the network's speed on a CPU with
  /// AVX512-BF16 or AMX, slower elsewhere; normals within ~0.01 degree of float32's; a model
  /// without the names casts whole, RMS +4 % on smooth noisy surfaces); "auto" = bfloat16 where
  /// both the CPU has AVX512-BF16 and the model names its layers, else float32
  /// (docs/design/decisions.md, "NH-Net in bfloat16").
  std::string precision = kPrecisions[0];
  /// An already loaded model; when set, `path` and `device` are not used. Lets a front end check
  /// the model before reading any input and reuse it across files.
  std::shared_ptr<const NhNetModel> loaded;
  /// Block size: points whose descriptors are computed and run through the model at once.
  int batch = 4096;
  /// Mix the network's normals with the PCA and MFPS candidates (candidate_mix.hpp; not the
  /// paper's, lower RMS); false = the network's normals as they are (the paper's NH-Net).
  bool candidate_mix = true;
  /// With the candidate mix: refit each mixed normal by the learned weighted jet fit
  /// (learned_fit.hpp; not the paper's, lower RMS); false = the mix's normals.
  bool learned_fit = true;
  /// With the candidate mix: where the network runs (Refine above). Moved costs RMS on noisy
  /// smooth surfaces, where the network's denoising is the best candidate, but little on clean
  /// clouds; Auto takes each where it pays (docs/design/decisions.md, "Refine auto").
  Refine refine = Refine::Auto;
  /// Refine::Auto: the network runs on every point when the cloud's noise ratio
  /// (EstimateResult::noise_ratio) is at least this, else only on the moved points. Below 0.02
  /// (20 of 105 noise-free benchmark clouds, no noisy one: those start at 0.047) the network on
  /// every point lowered the RMS by 0.10 degrees on average for 3.8x the time
  /// (docs/benchmark/candidate-mix/refine-auto.md).
  double auto_noise_ratio = 0.02;
  /// With the candidate mix and the network on every point (above): on a cloud whose noise
  /// makes neighbourhoods of many points, the network describes every network_stride-th point
  /// along the cloud's Morton curve, the points MFPS moved, and every point whose PCA normal is
  /// more than network_gate_deg off that of its nearest strided point; the others take the mean
  /// of their described neighbours' network normals (a smooth patch's network normals agree over
  /// a few spacings; the gate keeps bends, thin parts and sparse clouds described). 0 =
  /// automatic: k_used / 16, from 1 to 8 (1M fandisk points at 0.125 % noise: k 147, stride 8,
  /// 26 % less time, RMS 8.352 -> 8.343 degrees; 100k clouds: within 0.05 degree; issue 56,
  /// docs/design/decisions.md#network-stride-on-dense-noisy-clouds-issue-56); 1 = every point.
  int network_stride = 0;
  /// See network_stride.
  double network_gate_deg = 2;
};

/// A loaded model. Loading checks the metadata the exporter wrote (descriptor version, size,
/// sigmas, patch size, neighbourhood factor, height normalisation) against this core's
/// descriptor and refuses a mismatch (InvalidOptions saying which field differs).
class NhNetModel {
 public:
  /// `device`: "auto" (CUDA when the linked libtorch has it and a GPU is visible, else CPU),
  /// "cpu" or "cuda" (InputError if unavailable). `threads`: intra-op threads, 0 = all cores.
  /// `precision`: one of kPrecisions (ModelOptions::precision).
  NhNetModel(const std::string& path, const std::string& device = "auto", int threads = 0,
             const std::string& precision = kPrecisions[0]);
  ~NhNetModel();
  NhNetModel(NhNetModel&&) noexcept;
  NhNetModel& operator=(NhNetModel&&) noexcept;

  /// "cpu" or "cuda": the device in use.
  const std::string& device() const;
  /// "float32" or "bfloat16": the arithmetic the network runs in ("auto" resolved).
  const std::string& precision() const;
  /// The metadata JSON stored in the model.
  const std::string& metadata() const;
  /// The descriptor version the model was trained on (descriptor_options gives its options).
  int descriptor_version() const;

  /// Unit normals in the canonical frame for every row of `features` (N x D), `batch` rows at a
  /// time. Rows with non-finite features give NaN.
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> infer(const DescriptorMatrix& features,
                                                                 int batch = 4096,
                                                                 const RunContext& run = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// options.loaded, or else the model options.path (empty = default_model_path()) loaded for
/// options.device and options.precision with `threads` intra-op threads (0 = all cores).
std::shared_ptr<const NhNetModel> model_for(const ModelOptions& options, int threads = 0);

}  // namespace nhnet
