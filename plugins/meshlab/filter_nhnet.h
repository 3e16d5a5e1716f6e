// MeshLab filter plugin (Debian's MeshLab 2020.09 ABI): nhnet's normal estimation and
// normal-guided denoising in MeshLab's Filters menu (Point Set, Normals, Smoothing). A thin
// adapter over the core: vertex positions (and normals) are copied in, nhnet::estimate_normals /
// nhnet::denoise_points run, normals / positions are copied out. No algorithm lives here.
#pragma once

#include <common/interfaces.h>

#include "nhnet/orient/auto.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <functional>

class NhnetFilterPlugin : public QObject, public MeshFilterInterface {
  Q_OBJECT
  MESHLAB_PLUGIN_IID_EXPORTER(MESH_FILTER_INTERFACE_IID)
  Q_INTERFACES(MeshFilterInterface)

 public:
  enum { FP_ESTIMATE_NORMALS, FP_DENOISE };

  NhnetFilterPlugin();

  QString pluginName() const override;
  QString filterName(FilterIDType filter) const override;
  QString filterInfo(FilterIDType filter) const override;
  FilterClass getClass(QAction* action) override;
  FILTER_ARITY filterArity(QAction* action) const override;
  int getPreConditions(QAction* action) const override;
  int postCondition(QAction* action) const override;
  void initParameterSet(QAction* action, MeshModel& m, RichParameterList& par) override;
  bool applyFilter(QAction* action, MeshDocument& md, const RichParameterList& par,
                   vcg::CallBackPos* cb) override;

 private:
  /// The filters; they throw nhnet's exceptions (or any other) on failure and write to the mesh
  /// only after the core call succeeded.
  void estimate(MeshModel& mm, const RichParameterList& par, vcg::CallBackPos* cb);
  void denoise(MeshModel& mm, const RichParameterList& par, vcg::CallBackPos* cb);
  /// Runs `work` (a core call) on a worker thread while this thread polls its progress:
  /// MeshLab's callback, a Cancel dialog in the GUI (nhplugin::run_polled). Throws
  /// nhnet::Cancelled on a cancel, after logging how long stopping took.
  void runPolled(vcg::CallBackPos* cb,
                 const std::function<void(const nhnet::ProgressCallback&)>& work);
  nhnet::EstimateOptions estimateOptions(const RichParameterList& par);
  nhnet::OrientPlan orientPlan(const RichParameterList& par, const nhnet::Cloud& cloud);
  /// Sets errorMessage and writes it to MeshLab's log (meshlabserver prints only the log).
  void fail(const QString& message);
};
