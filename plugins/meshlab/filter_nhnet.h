// MeshLab filter plugin (Debian's MeshLab 2020.09 ABI): nhnet's normal estimation in MeshLab's
// Filters > Point Set / Normals menus. A thin adapter over the core: vertex positions are copied
// in, nhnet::estimate_normals runs, normals are copied out. No algorithm lives here.
#pragma once

#include <common/interfaces.h>

class NhnetFilterPlugin : public QObject, public MeshFilterInterface {
  Q_OBJECT
  MESHLAB_PLUGIN_IID_EXPORTER(MESH_FILTER_INTERFACE_IID)
  Q_INTERFACES(MeshFilterInterface)

 public:
  enum { FP_ESTIMATE_NORMALS };

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
  /// Runs the filter; throws nhnet's exceptions (or any other) on failure.
  void run(int id, MeshModel& mm, const RichParameterList& par, vcg::CallBackPos* cb);
  /// Sets errorMessage and writes it to MeshLab's log (meshlabserver prints only the log).
  void fail(const QString& message);
};
