// CloudCompare standard plugin "NH-Net normals" (Debian's CloudCompare 2.11.3): two actions under
// Plugins, "Estimate normals (NH-Net)" and "Normal-guided denoise", on every selected cloud, and
// the -NHNET_NORMALS / -NHNET_DENOISE command-line commands (NhnetCommands.h).
#pragma once

#include "NhnetAdapter.h"

#include <ccStdPluginInterface.h>

#include <functional>
#include <vector>

class ccPointCloud;
class ccProgressDialog;

class NhnetPlugin : public QObject, public ccStdPluginInterface {
  Q_OBJECT
  Q_INTERFACES(ccStdPluginInterface)
  Q_PLUGIN_METADATA(IID "cccorp.cloudcompare.plugin.NhnetPlugin" FILE "info.json")

 public:
  explicit NhnetPlugin(QObject* parent = nullptr);
  ~NhnetPlugin() override = default;

  // ccStdPluginInterface
  void onNewSelection(const ccHObject::Container& selectedEntities) override;
  QList<QAction*> getActions() override;
  void registerCommands(ccCommandLineInterface* cmd) override;

 private:
  void estimateNormals();
  void denoise();
  /// Selected point clouds (meshes' vertices are not touched); says so on the console if none.
  std::vector<ccPointCloud*> selectedClouds() const;
  /// Runs `fn` on every cloud with its own progress dialog (Cancel stops the remaining clouds
  /// too), behind nhcc::guarded; errors, warnings and summaries go to the console.
  void forEachCloud(const QString& what, const std::vector<ccPointCloud*>& clouds,
                    const std::function<nhcc::Outcome(ccPointCloud&, const nhcc::RunUi&)>& fn);

  QAction* estimateAction_ = nullptr;
  QAction* denoiseAction_ = nullptr;
  nhcc::NormalsSettings normals_;  ///< last used in this session
  nhcc::DenoiseSettings denoise_;
};
