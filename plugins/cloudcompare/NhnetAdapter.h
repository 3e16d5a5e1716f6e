// Thin adapter between CloudCompare's ccPointCloud and the nhnet core, shared by the GUI actions
// and the -NHNET_* command-line commands: settings with the core's defaults, copy the points (and
// the cloud's scan grids / sensors) in, call nhnet::estimate_normals, nhnet::resolve_orientation,
// nhnet::orient_normals / nhnet::denoise_points, copy normals or points out. No algorithm lives
// here. Nothing in this file touches a widget except run_with_progress (a dialog pointer).
#pragma once

#include "nhnet/errors.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/progress.hpp"

#include <QString>
#include <QStringList>

#include <array>
#include <functional>

// NHNET_CC_HAS_DENOISE is set by CMakeLists.txt from whether the core has its denoise stage (a
// compile definition, so the build notices when the stage arrives).
#if NHNET_CC_HAS_DENOISE
#include "nhnet/denoise/denoise.hpp"
#endif

class ccPointCloud;
class ccProgressDialog;

namespace nhcc {

/// The orientations offered (GUI list and -ORIENT), the core's names ("auto", "keep", ...): auto
/// (the core's default, nhnet::resolve_orientation: the cloud's normals, else its scan grids or
/// sensors, else MST), keep, viewpoint, mst, up, none.
QStringList orient_names();
/// Parses a name of orient_names() (case-insensitive); throws nhnet::InvalidOptions otherwise.
nhnet::OrientMode orient_from_string(const QString& name);

/// Names of the core's estimators offered (GUI list and -METHOD). Adding a method to the plugin
/// is one line in NhnetAdapter.cpp.
QStringList method_names();
/// The core's default method (nhnet::default_method: nhnet when its model is installed, else
/// mfps); `fallback_why`, when given, says why it is not nhnet ("" when it is).
QString default_method_name(QString* fallback_why = nullptr);
/// Whether the named method reads a model file (NormalsSettings::model).
bool method_uses_model(const QString& name);

/// Settings of "Estimate normals (NH-Net)" / -NHNET_NORMALS. Defaults are the core's.
struct NormalsSettings {
  /// Estimator, one of method_names() (default: the core's, default_method_name()).
  QString method;
  /// Why the default method is not nhnet; warned about (as nhnet-cli does) while `method` is
  /// that default. Cleared when the method is chosen explicitly (-METHOD).
  QString fallback_why;
  /// MFPS patch sizes: "auto" (chosen from the cloud's noise level) or a list like "50,100,150".
  QString scales;
  /// Sign handling (default: the core's, auto).
  nhnet::OrientMode orient;
  /// Sensor position for nhnet::OrientMode::Viewpoint, in the cloud's (local) coordinates.
  std::array<double, 3> viewpoint;
  /// Worker threads, 0 = all cores.
  int threads;
  /// TorchScript model file for the learned method; empty = the installed default model.
  QString model;
  /// The learned method's arithmetic, one of nhnet::kPrecisions (default: the core's, auto).
  QString precision;
  /// Also store each normal's confidence as the scalar field "NH-Net confidence" (default: the
  /// core's nhnet::kPluginConfidence).
  bool confidence;

  NormalsSettings();
};

/// Whether this build's core has the normal-guided denoiser (paper Eq. 9).
bool denoise_available();

/// Settings of "Normal-guided denoise" / -NHNET_DENOISE. Defaults are the core's.
struct DenoiseSettings {
  /// Update steps (the core's default; paper: 20).
  int iterations;
  /// Ball radius in the cloud's units; 0 = chosen by the core from the average spacing.
  double radius;
  /// Which normals guide the update: "input" (the cloud's own normals), a method name of
  /// method_names() (estimate them first with `estimate`'s other settings), or "auto": the
  /// cloud's normals when it has some, else the default method.
  QString normals = "auto";
  /// Settings of the estimation run when `normals` names a method.
  NormalsSettings estimate;

  DenoiseSettings();
};

/// Where a run reports: a GUI progress dialog (its Cancel button cancels), or console lines (the
/// command line, which has no dialog), or neither.
struct RunUi {
  /// Progress dialog of the GUI action; null on the command line.
  ccProgressDialog* dialog = nullptr;
  /// Prints one console line (progress every 10 %, the cancel delay); empty = silent.
  std::function<void(const QString&)> print;
};

/// What one run did, for the console.
struct Outcome {
  QString summary;       ///< one line: counts and the parameters actually used
  QStringList warnings;  ///< the core's non-fatal notes
};

/// Estimates normals of `cloud` and stores them in it (only once everything succeeded: a
/// failure or a cancel leaves the cloud as it was). Failed points get a zero normal.
Outcome estimate_cloud_normals(ccPointCloud& cloud, const NormalsSettings& settings,
                               const RunUi& ui);

/// Moves the points of `cloud` (normal-guided denoise); when the normals were estimated first,
/// stores them in the cloud too. Leaves the cloud untouched on failure or cancel.
Outcome denoise_cloud(ccPointCloud& cloud, const DenoiseSettings& settings, const RunUi& ui);

/// Runs `work` on a worker thread with a progress callback while this thread (the GUI thread)
/// keeps the dialog painted and responsive (nhplugin::run_polled); its Cancel button (or the
/// NHNET_PLUGIN_CANCEL_AT test hook) makes the callback return false, so the core throws
/// nhnet::Cancelled. Exceptions thrown by `work` are rethrown here.
void run_with_progress(const RunUi& ui,
                       const std::function<void(const nhnet::ProgressCallback&)>& work);

/// Runs `fn` and turns every exception into a message (empty = success): the boundary that keeps
/// CloudCompare up whatever happens in the core, std::bad_alloc included. `cancelled` is set
/// when the user cancelled.
QString guarded(const std::function<void()>& fn, bool* cancelled = nullptr);

}  // namespace nhcc
