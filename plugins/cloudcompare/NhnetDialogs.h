// The two small parameter dialogs of the plugin's GUI actions, filled with the core's defaults
// (or the values used last in this session).
#pragma once

#include "NhnetAdapter.h"

#include <QDialog>

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLineEdit;
class QPushButton;
class QSpinBox;

namespace nhcc {

/// "Estimate normals (NH-Net)": method, scales, orientation (+ viewpoint), threads, model file,
/// the model's precision.
class EstimateDialog : public QDialog {
  Q_OBJECT
 public:
  EstimateDialog(const NormalsSettings& initial, QWidget* parent);
  NormalsSettings settings() const;

 private:
  void updateEnabled();

  QComboBox* method_;
  QLineEdit* scales_;
  QComboBox* orient_;
  QDoubleSpinBox* viewpoint_[3];
  QSpinBox* threads_;
  QLineEdit* model_;
  QPushButton* browse_;
  QComboBox* precision_;
  QCheckBox* confidence_;
};

/// "Normal-guided denoise": iterations, radius, which normals (the cloud's or estimated), and
/// the network's precision when they are estimated by nhnet.
class DenoiseDialog : public QDialog {
  Q_OBJECT
 public:
  DenoiseDialog(const DenoiseSettings& initial, QWidget* parent);
  DenoiseSettings settings() const;

 private:
  DenoiseSettings base_;
  QSpinBox* iterations_;
  QDoubleSpinBox* radius_;
  QComboBox* normals_;
  QComboBox* precision_;
  QSpinBox* threads_;
};

}  // namespace nhcc
