// Parameter dialogs of the plugin (see NhnetDialogs.h). Widgets only: checks happen in the adapter.
#include "NhnetDialogs.h"

#include "../common/precision_list.hpp"

#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLineEdit>
#include <QPushButton>
#include <QSpinBox>
#include <QVBoxLayout>

#include <limits>

namespace nhcc {

namespace {

QSpinBox* threads_box(int value, QWidget* parent) {
  auto* box = new QSpinBox(parent);
  box->setRange(0, 1024);
  box->setSpecialValueText("all cores");
  box->setValue(value);
  return box;
}

/// The network's precision (nhnet::kPrecisions), `value` selected.
QComboBox* precision_box(const QString& value, QWidget* parent) {
  auto* box = new QComboBox(parent);
  box->addItems(nhplugin::precision_list());
  box->setCurrentText(value);
  box->setToolTip(nhplugin::precision_help());
  return box;
}

/// OK / Cancel under `form`.
void finish(QDialog* dialog, QFormLayout* form) {
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, dialog);
  QObject::connect(buttons, &QDialogButtonBox::accepted, dialog, &QDialog::accept);
  QObject::connect(buttons, &QDialogButtonBox::rejected, dialog, &QDialog::reject);
  auto* layout = new QVBoxLayout(dialog);
  layout->addLayout(form);
  layout->addWidget(buttons);
}

}  // namespace

EstimateDialog::EstimateDialog(const NormalsSettings& initial, QWidget* parent) : QDialog(parent) {
  setWindowTitle("Estimate normals (NH-Net)");
  auto* form = new QFormLayout;

  method_ = new QComboBox(this);
  method_->addItems(method_names());
  method_->setCurrentText(initial.method);
  method_->setToolTip(
      "nhnet: MFPS refined by the learned model (the default when its model is installed). "
      "mfps: PCA on smooth points, multi-scale patch selection near sharp features. "
      "pca: plain PCA.");
  form->addRow("Method", method_);

  scales_ = new QLineEdit(initial.scales, this);
  scales_->setToolTip(
      "MFPS patch sizes in points: 'auto' (from the cloud's noise level) or a "
      "list like 50,100,150");
  form->addRow("Scales", scales_);

  orient_ = new QComboBox(this);
  const QStringList names = orient_names();
  orient_->addItems(names);
  orient_->setCurrentText(nhnet::to_string(initial.orient));
  orient_->setToolTip(
      "auto (default): keep the cloud's signs if it has normals, else towards the scanner of "
      "each point when the cloud has scan grids or a sensor (PTX, E57...), else MST; "
      "keep: agree with the cloud's normals; viewpoint: towards the position below; "
      "mst: consistent signs over each connected part (outward on closed surfaces); "
      "up: facing +z (airborne scans); none: arbitrary signs");
  form->addRow("Orientation", orient_);

  auto* vp = new QHBoxLayout;
  for (int i = 0; i < 3; ++i) {
    viewpoint_[i] = new QDoubleSpinBox(this);
    viewpoint_[i]->setRange(-std::numeric_limits<double>::max(),
                            std::numeric_limits<double>::max());
    viewpoint_[i]->setDecimals(4);
    viewpoint_[i]->setValue(initial.viewpoint[size_t(i)]);
    vp->addWidget(viewpoint_[i]);
  }
  form->addRow("Viewpoint (x y z)", vp);

  threads_ = threads_box(initial.threads, this);
  form->addRow("Threads", threads_);

  auto* modelRow = new QHBoxLayout;
  model_ = new QLineEdit(initial.model, this);
  model_->setPlaceholderText("installed default model");
  browse_ = new QPushButton("...", this);
  modelRow->addWidget(model_);
  modelRow->addWidget(browse_);
  connect(browse_, &QPushButton::clicked, this, [this] {
    const QString f = QFileDialog::getOpenFileName(this, "NH-Net model", model_->text(),
                                                   "TorchScript model (*.pt);;All files (*)");
    if (!f.isEmpty()) model_->setText(f);
  });
  form->addRow("Model file", modelRow);

  precision_ = precision_box(initial.precision, this);
  form->addRow("Precision", precision_);

  confidence_ = new QCheckBox("scalar field \"NH-Net confidence\"", this);
  confidence_->setChecked(initial.confidence);
  confidence_->setToolTip(
      "Each normal's confidence in [0, 1]: the chance that it is within 30 degrees of the true "
      "normal, judged from its neighbourhood");
  form->addRow("Confidence", confidence_);

  connect(method_, &QComboBox::currentTextChanged, this, [this] { updateEnabled(); });
  connect(orient_, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
          [this] { updateEnabled(); });
  updateEnabled();
  finish(this, form);
}

void EstimateDialog::updateEnabled() {
  const bool model = method_uses_model(method_->currentText());
  model_->setEnabled(model);
  browse_->setEnabled(model);
  precision_->setEnabled(model);
  const bool vp = orient_->currentText() == nhnet::to_string(nhnet::OrientMode::Viewpoint);
  for (auto* box : viewpoint_) box->setEnabled(vp);
  scales_->setEnabled(method_->currentText() != nhnet::to_string(nhnet::Method::Pca));
}

NormalsSettings EstimateDialog::settings() const {
  NormalsSettings s;
  if (method_->currentText() != s.method) s.fallback_why.clear();  // chosen, not the default
  s.method = method_->currentText();
  s.scales = scales_->text();
  s.orient = orient_from_string(orient_->currentText());
  for (size_t i = 0; i < 3; ++i) s.viewpoint[i] = viewpoint_[i]->value();
  s.threads = threads_->value();
  s.model = model_->text().trimmed();
  s.precision = precision_->currentText();
  s.confidence = confidence_->isChecked();
  return s;
}

DenoiseDialog::DenoiseDialog(const DenoiseSettings& initial, QWidget* parent)
    : QDialog(parent), base_(initial) {
  setWindowTitle("Normal-guided denoise");
  auto* form = new QFormLayout;

  iterations_ = new QSpinBox(this);
  iterations_->setRange(1, 1000);
  iterations_->setValue(initial.iterations);
  form->addRow("Iterations", iterations_);

  radius_ = new QDoubleSpinBox(this);
  radius_->setRange(0, std::numeric_limits<double>::max());
  radius_->setDecimals(6);
  radius_->setSpecialValueText("auto (from the point spacing)");
  radius_->setValue(initial.radius);
  form->addRow("Radius", radius_);

  normals_ = new QComboBox(this);
  normals_->addItem("the cloud's normals", "input");
  for (const QString& m : method_names()) normals_->addItem("estimate with " + m, m);
  const int at = normals_->findData(initial.normals);
  normals_->setCurrentIndex(at < 0 ? 0 : at);
  form->addRow("Normals", normals_);

  // The precision of the network that estimates the normals (method nhnet only).
  precision_ = precision_box(initial.estimate.precision, this);
  form->addRow("Precision", precision_);
  const auto enable = [this] {
    precision_->setEnabled(method_uses_model(normals_->currentData().toString()));
  };
  connect(normals_, QOverload<int>::of(&QComboBox::currentIndexChanged), this, enable);
  enable();

  threads_ = threads_box(initial.estimate.threads, this);
  form->addRow("Threads", threads_);
  finish(this, form);
}

DenoiseSettings DenoiseDialog::settings() const {
  DenoiseSettings s = base_;
  s.iterations = iterations_->value();
  s.radius = radius_->value();
  s.normals = normals_->currentData().toString();
  s.estimate.threads = threads_->value();
  s.estimate.precision = precision_->currentText();
  return s;
}

}  // namespace nhcc
