// GUI side of the plugin: actions, dialogs, one progress dialog per cloud, console messages.
// Every call into the core goes through nhcc::guarded, so no exception reaches CloudCompare.
#include "NhnetPlugin.h"

#include "NhnetCommands.h"
#include "NhnetDialogs.h"

#include <ccPointCloud.h>
#include <ccProgressDialog.h>

#include <QAction>
#include <QMainWindow>

#include <memory>
#include <new>

NhnetPlugin::NhnetPlugin(QObject* parent)
    : QObject(parent), ccStdPluginInterface(":/CC/plugin/NhnetPlugin/info.json") {}

void NhnetPlugin::onNewSelection(const ccHObject::Container& selectedEntities) {
  bool any = false;
  for (ccHObject* e : selectedEntities) any = any || (e && e->isA(CC_TYPES::POINT_CLOUD));
  if (estimateAction_) estimateAction_->setEnabled(any);
  if (denoiseAction_) denoiseAction_->setEnabled(any && nhcc::denoise_available());
}

QList<QAction*> NhnetPlugin::getActions() {
  if (!estimateAction_) {
    estimateAction_ = new QAction("Estimate normals (NH-Net)", this);
    estimateAction_->setToolTip(
        "Estimate normals of the selected clouds (NH-Net / MFPS / PCA; sharp features kept; "
        "signs towards the cloud's scanner when it has one)");
    estimateAction_->setIcon(getIcon());
    connect(estimateAction_, &QAction::triggered, this, &NhnetPlugin::estimateNormals);

    denoiseAction_ = new QAction("Normal-guided denoise", this);
    denoiseAction_->setToolTip(
        nhcc::denoise_available()
            ? "Move the points of the selected clouds onto the surface their normals describe "
              "(paper Eq. 9); the result is a new cloud"
            : "Not in this build: nhnet's denoise stage was not found when the plugin was built");
    denoiseAction_->setIcon(getIcon());
    connect(denoiseAction_, &QAction::triggered, this, &NhnetPlugin::denoise);
  }
  return {estimateAction_, denoiseAction_};
}

void NhnetPlugin::registerCommands(ccCommandLineInterface* cmd) {
  if (!cmd) return;
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new nhcc::CommandNormals));
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new nhcc::CommandDenoise));
}

std::vector<ccPointCloud*> NhnetPlugin::selectedClouds() const {
  std::vector<ccPointCloud*> out;
  if (!m_app) return out;
  for (ccHObject* e : m_app->getSelectedEntities())
    if (e && e->isA(CC_TYPES::POINT_CLOUD)) out.push_back(static_cast<ccPointCloud*>(e));
  if (out.empty())
    m_app->dispToConsole("[NH-Net] select at least one point cloud",
                         ccMainAppInterface::ERR_CONSOLE_MESSAGE);
  return out;
}

void NhnetPlugin::forEachCloud(
    const QString& what, const std::vector<ccPointCloud*>& clouds,
    const std::function<nhcc::Outcome(ccPointCloud&, const nhcc::RunUi&)>& fn) {
  for (size_t i = 0; i < clouds.size(); ++i) {
    ccPointCloud* cloud = clouds[i];
    ccProgressDialog progress(true, m_app->getMainWindow());
    progress.setMethodTitle(
        QString("NH-Net %1: %2 (%3/%4)").arg(what, cloud->getName()).arg(i + 1).arg(clouds.size()));
    nhcc::Outcome out;
    bool cancelled = false;
    nhcc::RunUi ui;
    ui.dialog = &progress;
    const QString error = nhcc::guarded([&] { out = fn(*cloud, ui); }, &cancelled);
    const QString name = QString("[NH-Net] %1 '%2': ").arg(what, cloud->getName());
    if (!error.isEmpty()) {
      m_app->dispToConsole(name + error, cancelled ? ccMainAppInterface::WRN_CONSOLE_MESSAGE
                                                   : ccMainAppInterface::ERR_CONSOLE_MESSAGE);
      if (cancelled) break;  // Cancel stops the remaining clouds too
      continue;
    }
    for (const QString& w : out.warnings)
      m_app->dispToConsole(name + w, ccMainAppInterface::WRN_CONSOLE_MESSAGE);
    m_app->dispToConsole(name + out.summary, ccMainAppInterface::STD_CONSOLE_MESSAGE);
  }
  m_app->updateUI();
  m_app->refreshAll();
}

void NhnetPlugin::estimateNormals() {
  const std::vector<ccPointCloud*> clouds = selectedClouds();
  if (clouds.empty()) return;
  nhcc::EstimateDialog dlg(normals_, m_app->getMainWindow());
  if (!dlg.exec()) return;
  normals_ = dlg.settings();
  forEachCloud("normals", clouds, [this](ccPointCloud& cloud, const nhcc::RunUi& ui) {
    nhcc::Outcome out = nhcc::estimate_cloud_normals(cloud, normals_, ui);
    cloud.prepareDisplayForRefresh_recursive();
    return out;
  });
}

void NhnetPlugin::denoise() {
  if (!m_app) return;
  if (!nhcc::denoise_available()) {
    m_app->dispToConsole(
        "[NH-Net] normal-guided denoise is not in this build (nhnet's denoise "
        "stage was not found when the plugin was built)",
        ccMainAppInterface::ERR_CONSOLE_MESSAGE);
    return;
  }
  const std::vector<ccPointCloud*> clouds = selectedClouds();
  if (clouds.empty()) return;
  nhcc::DenoiseSettings initial = denoise_;
  if (initial.normals == "auto") {
    bool allHaveNormals = true;
    for (ccPointCloud* c : clouds) allHaveNormals = allHaveNormals && c->hasNormals();
    initial.normals = allHaveNormals ? QString("input") : initial.estimate.method;
  }
  nhcc::DenoiseDialog dlg(initial, m_app->getMainWindow());
  if (!dlg.exec()) return;
  denoise_ = dlg.settings();
  forEachCloud("denoise", clouds, [this](ccPointCloud& cloud, const nhcc::RunUi& ui) {
    // The result is a new cloud next to the input, which stays as it was (hidden).
    std::unique_ptr<ccPointCloud> result(cloud.cloneThis());
    if (!result) throw std::bad_alloc();
    result->setName(cloud.getName() + ".denoised");
    nhcc::Outcome out = nhcc::denoise_cloud(*result, denoise_, ui);
    cloud.setEnabled(false);
    m_app->addToDB(result.release());
    return out;
  });
}
