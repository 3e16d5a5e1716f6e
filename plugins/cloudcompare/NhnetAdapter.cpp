// Thin adapter between ccPointCloud and the nhnet core (see NhnetAdapter.h).
#include "NhnetAdapter.h"

#include "../common/polled_run.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"

// CloudCompare
#include <ccHObjectCaster.h>
#include <ccPointCloud.h>
#include <ccProgressDialog.h>
#include <ccSensor.h>

// Qt
#include <QCoreApplication>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <new>

namespace nhcc {

namespace {

/// The core's estimators offered by the plugin (GUI list and -METHOD).
const nhnet::Method kMethods[] = {nhnet::Method::NhNet, nhnet::Method::Mfps, nhnet::Method::Pca};

/// Methods that read a TorchScript model (the model setting is ignored by the others).
bool uses_model(nhnet::Method m) { return m == nhnet::Method::NhNet; }

/// The orientations offered (GUI list and -ORIENT). Sensors is reached through Auto only (it
/// needs a sensor per point, which the cloud's scan grids give).
const nhnet::OrientMode kOrients[] = {nhnet::OrientMode::Auto,      nhnet::OrientMode::Keep,
                                      nhnet::OrientMode::Viewpoint, nhnet::OrientMode::Mst,
                                      nhnet::OrientMode::Up,        nhnet::OrientMode::None};

std::string str(const QString& s) { return s.toStdString(); }

/// "auto" or "" -> {} (chosen by the core), "50,100,150" -> {50, 100, 150}. The core checks ranges.
std::vector<int> parse_scales(const QString& text) {
  const QString t = text.trimmed();
  if (t.isEmpty() || t.compare("auto", Qt::CaseInsensitive) == 0) return {};
  std::vector<int> out;
  for (const QString& part : t.split(',')) {
    bool ok = false;
    const int v = part.trimmed().toInt(&ok);
    if (!ok)
      throw nhnet::InvalidOptions(
          "scales must be 'auto' or integers separated by commas (e.g. "
          "50,100,150), got '" +
          str(text) + "'");
    out.push_back(v);
  }
  return out;
}

/// {} -> "auto", {50, 100, 150} -> "50,100,150" (parse_scales' inverse).
QString scales_text(const std::vector<int>& scales) {
  QStringList parts;
  for (int v : scales) parts << QString::number(v);
  return parts.isEmpty() ? QString("auto") : parts.join(',');
}

struct Prepared {
  nhnet::EstimateOptions options;
  QStringList warnings;
};

/// Checks the settings (no point is read before they are valid) and maps them to core options.
Prepared prepare(const NormalsSettings& s) {
  Prepared p;
  p.options.method = nhnet::method_from_string(str(s.method.trimmed().toLower()));
  p.options.mfps.scales = parse_scales(s.scales);
  if (s.threads < 0) throw nhnet::InvalidOptions("threads must be >= 0 (0 = all cores)");
  p.options.run.threads = s.threads;
  p.options.confidence = s.confidence;
  if (p.options.method == nhnet::Method::Pca && !p.options.mfps.scales.empty())
    p.warnings << "scales are ignored by the pca method";
  if (!s.model.isEmpty() && !uses_model(p.options.method))
    p.warnings << QString("model file ignored: method %1 uses no model").arg(s.method);
  const QString precision = s.precision.trimmed().toLower();
  nhnet::check_precision(str(precision), "precision");
  if (precision != nhnet::ModelOptions{}.precision.c_str() && !uses_model(p.options.method))
    p.warnings << QString("precision ignored: method %1 uses no model").arg(s.method);
  if (uses_model(p.options.method)) {
    p.options.model.path = str(s.model.trimmed());  // empty = shipped
    p.options.model.precision = str(precision);
  }
  if (!s.fallback_why.isEmpty() && p.options.method != nhnet::Method::NhNet)
    p.warnings << QString("method %1 (%2; method nhnet needs it)")
                      .arg(nhnet::to_string(p.options.method), s.fallback_why);
  return p;
}

nhnet::Points copy_points(const ccPointCloud& cloud) {
  const unsigned n = cloud.size();
  nhnet::Points pts(Eigen::Index(n), 3);
  for (unsigned i = 0; i < n; ++i) {
    const CCVector3* p = cloud.getPoint(i);
    pts(i, 0) = p->x;
    pts(i, 1) = p->y;
    pts(i, 2) = p->z;
  }
  return pts;
}

nhnet::Normals copy_normals(const ccPointCloud& cloud) {
  const unsigned n = cloud.size();
  nhnet::Normals nrm(Eigen::Index(n), 3);
  for (unsigned i = 0; i < n; ++i) {
    const CCVector3& v = cloud.getPointNormal(i);
    nrm(i, 0) = v.x;
    nrm(i, 1) = v.y;
    nrm(i, 2) = v.z;
  }
  return nrm;
}

/// Stores N x 3 normals; NaN rows (failed points) become zero normals.
void store_normals(ccPointCloud& cloud, const nhnet::Normals& normals) {
  if (!cloud.resizeTheNormsTable()) throw std::bad_alloc();
  for (unsigned i = 0; i < cloud.size(); ++i) {
    const auto row = normals.row(Eigen::Index(i));
    const CCVector3 v = row.allFinite()
                            ? CCVector3(PointCoordinateType(row(0)), PointCoordinateType(row(1)),
                                        PointCoordinateType(row(2)))
                            : CCVector3(0, 0, 0);
    cloud.setPointNormal(i, v);
  }
  cloud.showNormals(true);
}

/// Stores the confidences (NaN where a point failed) as the scalar field "NH-Net confidence",
/// replacing one of that name, and shows it.
void store_confidence(ccPointCloud& cloud, const Eigen::VectorXd& confidence) {
  const char* name = "NH-Net confidence";
  const int old = cloud.getScalarFieldIndexByName(name);
  if (old >= 0) cloud.deleteScalarField(old);
  const int index = cloud.addScalarField(name);
  if (index < 0) throw std::bad_alloc();
  CCLib::ScalarField* sf = cloud.getScalarField(index);
  for (unsigned i = 0; i < cloud.size(); ++i)
    sf->setValue(i, std::isfinite(confidence[Eigen::Index(i)])
                        ? ScalarType(confidence[Eigen::Index(i)])
                        : NAN_VALUE);
  sf->computeMinAndMax();
  cloud.setCurrentDisplayedScalarField(index);
  cloud.showSF(true);
}

Eigen::Vector3d vec(const CCVector3d& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

/// The 3 x 3 rotation of a column-major 4 x 4 matrix (ccGLMatrix / ccGLMatrixd).
template <class T>
Eigen::Matrix3d rotation_of(const T* m) {
  Eigen::Matrix3d r;
  for (int c = 0; c < 3; ++c)
    for (int row = 0; row < 3; ++row) r(row, c) = double(m[4 * c + row]);
  return r;
}

/// The cloud's scan grids (PTX, E57 and other gridded loaders; merged scans keep one each): one
/// sensor per grid at the grid's sensor position, and per point the grid that holds it. False
/// (nothing added) when there are none or they do not cover every point.
bool add_grid_sensors(const ccPointCloud& cc, nhnet::Cloud& cloud) {
  if (cc.gridCount() == 0) return false;
  std::vector<int32_t> index(cc.size(), -1);
  std::vector<nhnet::Sensor> sensors;
  for (size_t g = 0; g < cc.gridCount(); ++g) {
    const ccPointCloud::Grid::Shared& grid = cc.grid(g);
    if (!grid || grid->indexes.size() != size_t(grid->w) * grid->h) return false;
    for (int i : grid->indexes)
      if (i >= 0 && unsigned(i) < cc.size()) index[size_t(i)] = int32_t(sensors.size());
    nhnet::Sensor s;
    s.position = vec(grid->sensorPosition.getTranslationAsVec3D());
    s.rotation = rotation_of(grid->sensorPosition.data());
    s.source =
        QString("CloudCompare scan grid %1 of %2").arg(g + 1).arg(cc.gridCount()).toStdString();
    sensors.push_back(s);
  }
  if (std::find(index.begin(), index.end(), -1) != index.end()) return false;
  cloud.sensors = std::move(sensors);
  if (cloud.sensors.size() > 1) cloud.sensor_index = std::move(index);
  return true;
}

/// The sensor objects under the cloud (ccGBLSensor from the PTX / E57 / PCD loaders,
/// ccCameraSensor): a single one took every point. Several without a scan grid say nothing about
/// which point each took: none is used then (a warning says so).
void add_child_sensors(ccPointCloud& cc, nhnet::Cloud& cloud, QStringList& warnings) {
  std::vector<ccSensor*> found;
  for (unsigned i = 0; i < cc.getChildrenNumber(); ++i)
    if (ccSensor* s = ccHObjectCaster::ToSensor(cc.getChild(i))) found.push_back(s);
  if (found.size() > 1)
    warnings << QString(
                    "%1 sensors under the cloud but no scan grid saying which point each took: "
                    "none used")
                    .arg(found.size());
  if (found.size() != 1) return;
  ccIndexedTransformation t;
  if (!found[0]->getActiveAbsoluteTransformation(t)) return;
  nhnet::Sensor s;
  s.position = vec(CCVector3d::fromArray(t.getTranslationAsVec3D().u));
  s.rotation = rotation_of(t.data());
  s.source = ("CloudCompare sensor '" + found[0]->getName() + "'").toStdString();
  cloud.sensors.push_back(s);
}

/// The points, the normals when `with_normals`, and the sensors of a CloudCompare cloud.
nhnet::Cloud cloud_in(ccPointCloud& cc, bool with_normals, QStringList& warnings) {
  nhnet::Cloud cloud;
  cloud.points = copy_points(cc);
  if (with_normals) cloud.normals = copy_normals(cc);
  if (!add_grid_sensors(cc, cloud)) add_child_sensors(cc, cloud, warnings);
  return cloud;
}

/// The settings' orientation made concrete for this cloud (auto: nhnet::resolve_orientation).
nhnet::OrientPlan plan_orientation(const NormalsSettings& s, const nhnet::Cloud& cloud,
                                   QStringList& warnings) {
  nhnet::OrientOptions requested;
  requested.mode = s.orient;
  requested.run.threads = s.threads;
  requested.viewpoint = Eigen::Vector3d(s.viewpoint[0], s.viewpoint[1], s.viewpoint[2]);
  nhnet::OrientPlan plan = nhnet::resolve_orientation(cloud, requested);
  if (plan.options.mode == nhnet::OrientMode::Keep && !cloud.has_normals()) {
    warnings << "orientation keep: the cloud has no normals, so the signs stay arbitrary";
    plan.options.mode = nhnet::OrientMode::None;
  }
  return plan;
}

nhnet::ProgressCallback narrow(const nhnet::ProgressCallback& cb, double begin, double end) {
  if (!cb) return cb;
  return [cb, begin, end](double f, const std::string& stage) {
    return cb(begin + (end - begin) * f, stage);
  };
}

QString join(const std::vector<int>& v) {
  QStringList parts;
  for (int x : v) parts << QString::number(x);
  return parts.isEmpty() ? QString("-") : parts.join('/');
}

QStringList to_qt(const std::vector<std::string>& v) {
  QStringList out;
  for (const auto& s : v) out << QString::fromStdString(s);
  return out;
}

/// Runs the estimator; reports the parameters it used.
nhnet::EstimateResult run_estimate(const nhnet::Points& pts, nhnet::EstimateOptions opt,
                                   const nhnet::ProgressCallback& cb) {
  opt.run.progress = cb;
  return nhnet::estimate_normals(pts, opt);
}

/// ", orient MODE from SOURCE (F flipped, C components)".
QString describe_orientation(nhnet::OrientMode mode, const std::string& source,
                             const nhnet::OrientResult& ores) {
  QString text = QString(", orient %1 from %2").arg(nhnet::to_string(mode), source.c_str());
  if (mode == nhnet::OrientMode::None) return text;
  text += QString(" (%1 flipped").arg(ores.flipped);
  if (mode == nhnet::OrientMode::Mst) text += QString(", %1 components").arg(ores.components);
  return text + ")";
}

QString describe(const nhnet::EstimateResult& res, nhnet::Method method, Eigen::Index n) {
  const QString ran =
      QString::fromStdString(nhnet::network_phrase(res.device_used, res.precision_used));
  return QString(
             "%1 points, %2 failed, method %3%4, k %5, scales %6, noise ratio %7, %8 candidates")
      .arg(n)
      .arg(res.failed)
      .arg(nhnet::to_string(method))
      .arg(ran)
      .arg(res.k_used)
      .arg(join(res.scales_used))
      .arg(res.noise_ratio, 0, 'g', 3)
      .arg(res.candidates);
}

}  // namespace

NormalsSettings::NormalsSettings()
    : scales(scales_text(nhnet::MfpsOptions{}.scales)),
      orient(nhnet::kDefaultOrientMode),
      threads(nhnet::EstimateOptions{}.run.threads),
      precision(QString::fromStdString(nhnet::ModelOptions{}.precision)),
      confidence(nhnet::kPluginConfidence) {
  method = default_method_name(&fallback_why);  // fallback_why is constructed by now
  const Eigen::Vector3d vp = nhnet::OrientOptions{}.viewpoint;
  viewpoint = {{vp.x(), vp.y(), vp.z()}};
}

DenoiseSettings::DenoiseSettings() {
#if NHNET_CC_HAS_DENOISE
  const nhnet::DenoiseOptions d;
  iterations = d.iterations;
  radius = d.radius;
#else
  iterations = 20;  // paper Sec. 7
  radius = 0;
#endif
}

QStringList method_names() {
  QStringList out;
  for (nhnet::Method m : kMethods) out << nhnet::to_string(m);
  return out;
}

QString default_method_name(QString* fallback_why) {
  std::string why;
  const nhnet::Method m = nhnet::default_method(&why);
  if (fallback_why) *fallback_why = QString::fromStdString(why);
  return nhnet::to_string(m);
}

QStringList orient_names() {
  QStringList out;
  for (nhnet::OrientMode m : kOrients) out << nhnet::to_string(m);
  return out;
}

nhnet::OrientMode orient_from_string(const QString& name) {
  const int i = orient_names().indexOf(name.trimmed().toLower());
  if (i < 0)
    throw nhnet::InvalidOptions("unknown orientation '" + str(name) + "' (expected " +
                                str(orient_names().join(", ")) + ")");
  return kOrients[i];
}

bool method_uses_model(const QString& name) {
  for (nhnet::Method m : kMethods)
    if (name.trimmed().compare(nhnet::to_string(m), Qt::CaseInsensitive) == 0) return uses_model(m);
  return false;
}

bool denoise_available() { return NHNET_CC_HAS_DENOISE != 0; }

Outcome estimate_cloud_normals(ccPointCloud& cloud, const NormalsSettings& settings,
                               const RunUi& ui) {
  Prepared p = prepare(settings);
  Outcome out;
  out.warnings = p.warnings;
  // The cloud's normals serve keep (asked, or chosen by auto), and only those.
  const bool keep_asked =
      settings.orient == nhnet::OrientMode::Keep || settings.orient == nhnet::OrientMode::Auto;
  const nhnet::Cloud in = cloud_in(cloud, keep_asked && cloud.hasNormals(), out.warnings);
  const nhnet::OrientPlan plan = plan_orientation(settings, in, out.warnings);
  const nhnet::OrientOptions& orient = plan.options;

  nhnet::OrientedResult both;
  run_with_progress(ui, [&](const nhnet::ProgressCallback& cb) {
    both = nhnet::estimate_oriented(in.points, p.options, orient,
                                    nhnet::RunContext{p.options.run.threads, cb}, in.normals);
  });
  nhnet::EstimateResult& res = both.estimate;
  const nhnet::OrientResult& ores = both.orient;
  out.warnings << to_qt(res.warnings);
  if (ores.unoriented > 0)
    out.warnings << QString("orientation %1: %2 normals could not be oriented (left as estimated)")
                        .arg(nhnet::to_string(orient.mode))
                        .arg(ores.unoriented);
  store_normals(cloud, res.normals);
  if (res.confidence.size() == res.normals.rows()) store_confidence(cloud, res.confidence);
  out.summary = describe(res, p.options.method, in.points.rows()) +
                describe_orientation(orient.mode, plan.source, ores);
  return out;
}

Outcome denoise_cloud(ccPointCloud& cloud, const DenoiseSettings& settings, const RunUi& ui) {
#if NHNET_CC_HAS_DENOISE
  if (settings.iterations < 1) throw nhnet::InvalidOptions("iterations must be >= 1");
  if (!(settings.radius >= 0) || !std::isfinite(settings.radius))
    throw nhnet::InvalidOptions("radius must be >= 0 (0 = chosen from the point spacing)");
  Outcome out;
  QString which = settings.normals.trimmed().toLower();
  if (which == "auto") which = cloud.hasNormals() ? QString("input") : settings.estimate.method;
  const bool from_input = which == "input";
  Prepared p;
  if (!from_input) {
    NormalsSettings es = settings.estimate;
    es.method = which;
    es.orient = nhnet::OrientMode::None;  // the denoiser does not need signs
    es.confidence = false;                // nor confidences
    if (which != settings.estimate.method) es.fallback_why.clear();  // chosen, not the default
    p = prepare(es);
    out.warnings << p.warnings;
  } else if (!cloud.hasNormals()) {
    throw nhnet::InvalidOptions(
        "the cloud has no normals: estimate them first, or let the denoiser estimate them "
        "(normals: " +
        str(method_names().join(" / ")) + ")");
  }
  nhnet::DenoiseOptions dopt;
  dopt.iterations = settings.iterations;
  dopt.radius = settings.radius;
  dopt.run.threads = settings.estimate.threads;

  const nhnet::Points pts = copy_points(cloud);
  nhnet::Normals normals = from_input ? copy_normals(cloud) : nhnet::Normals();
  nhnet::EstimateResult est;
  nhnet::DenoiseResult res;
  run_with_progress(ui, [&](const nhnet::ProgressCallback& cb) {
    double split = 0;
    if (!from_input) {
      split = 0.5;
      est = run_estimate(pts, p.options, narrow(cb, 0, split));
      normals = est.normals;
    }
    dopt.run.progress = narrow(cb, split, 1);
    res = nhnet::denoise_points(pts, normals, dopt);
  });
  out.warnings << to_qt(est.warnings) << to_qt(res.warnings);

  // Normals first: the only step here that can fail (allocation) leaves the points untouched.
  if (!from_input) store_normals(cloud, normals);
  for (unsigned i = 0; i < cloud.size(); ++i) {
    const auto row = res.points.row(Eigen::Index(i));
    *const_cast<CCVector3*>(cloud.getPointPersistentPtr(i)) = CCVector3(
        PointCoordinateType(row(0)), PointCoordinateType(row(1)), PointCoordinateType(row(2)));
  }
  cloud.deleteOctree();
  cloud.invalidateBoundingBox();

  out.summary = QString(
                    "%1 points, %2 moved, %3 skipped, %4 isolated, %5 iterations, radius %6, "
                    "sigma %7, normals %8")
                    .arg(pts.rows())
                    .arg(res.moved)
                    .arg(res.skipped)
                    .arg(res.isolated)
                    .arg(settings.iterations)
                    .arg(res.radius, 0, 'g', 4)
                    .arg(res.sigma, 0, 'g', 3)
                    .arg(which);
  if (!from_input) out.summary += " (" + describe(est, p.options.method, pts.rows()) + ")";
  return out;
#else
  (void)cloud;
  (void)settings;
  (void)ui;
  throw nhnet::InvalidOptions(
      "normal-guided denoise is not in this build of nhnet: the core's denoise stage "
      "(nhnet/denoise/denoise.hpp) was not found when the plugin was built");
#endif
}

namespace {

/// Shows progress in the dialog; false once its Cancel button was pressed.
bool poll_dialog(ccProgressDialog& dialog, double f, const std::string& stage, std::string& shown) {
  if (stage != shown) {
    dialog.setInfo(QString::fromStdString(stage));
    shown = stage;
  }
  dialog.setValue(int(std::lround(100 * f)));
  QCoreApplication::processEvents();
  return !dialog.wasCanceled();
}

/// Prints "[NH-Net] 40 % (stage)" each time the progress passes another 10 %.
void poll_console(const RunUi& ui, double f, const std::string& stage, int& printed) {
  const int tenth = int(f * 10);
  if (!ui.print || tenth <= printed) return;
  printed = tenth;
  ui.print(QString("[NH-Net] %1 % (%2)").arg(10 * tenth).arg(QString::fromStdString(stage)));
}

void show_modal(ccProgressDialog& dialog) {
  // Modal: while the worker runs, nothing else in CloudCompare can delete or edit the cloud.
  dialog.setWindowModality(Qt::ApplicationModal);
  dialog.setRange(0, 100);
  dialog.setValue(0);
  dialog.show();
  QCoreApplication::processEvents();
}

}  // namespace

void run_with_progress(const RunUi& ui,
                       const std::function<void(const nhnet::ProgressCallback&)>& work) {
  if (ui.dialog) show_modal(*ui.dialog);
  const double cancel_at = nhplugin::test_cancel_at();
  std::string shown;
  int printed = 0;
  using Clock = std::chrono::steady_clock;
  Clock::time_point asked;
  const nhplugin::Poll poll = [&](double f, const std::string& stage) {
    poll_console(ui, f, stage, printed);
    const bool go = (!ui.dialog || poll_dialog(*ui.dialog, f, stage, shown)) && f < cancel_at;
    if (!go) asked = Clock::now();
    return go;
  };
  try {
    nhplugin::run_polled(work, poll);
  } catch (const nhnet::Cancelled&) {
    if (ui.dialog) ui.dialog->stop();
    const std::chrono::duration<double> delay = Clock::now() - asked;
    if (ui.print)
      ui.print(QString("[NH-Net] stopped %1 s after the cancel").arg(delay.count(), 0, 'f', 2));
    throw;
  } catch (...) {
    if (ui.dialog) ui.dialog->stop();
    throw;
  }
  if (ui.dialog) ui.dialog->stop();
}

QString guarded(const std::function<void()>& fn, bool* cancelled) {
  if (cancelled) *cancelled = false;
  try {
    fn();
    return {};
  } catch (const nhnet::Cancelled&) {
    if (cancelled) *cancelled = true;
    return "cancelled; the cloud was left unchanged";
  } catch (const std::bad_alloc&) {
    return "out of memory; the cloud was left unchanged (try a subsampled cloud or fewer "
           "threads)";
  } catch (const nhnet::InvalidOptions& e) {
    return QString("invalid parameter: ") + e.what();
  } catch (const std::exception& e) {
    return QString::fromStdString(e.what());
  } catch (...) {
    return "unexpected error (not a std::exception); the cloud may be unchanged";
  }
}

}  // namespace nhcc
