// Thin adapter between ccPointCloud and the nhnet core (see NhnetAdapter.h).
#include "NhnetAdapter.h"

// CloudCompare
#include <ccPointCloud.h>
#include <ccProgressDialog.h>

// Qt
#include <QCoreApplication>

#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <mutex>
#include <new>

namespace nhcc {

namespace {

/// The core's estimators offered by the plugin (GUI list and -METHOD), the core's default first.
/// NH-Net: add its nhnet::Method here.
const nhnet::Method kMethods[] = {nhnet::Method::Mfps, nhnet::Method::Pca, nhnet::Method::NhNet};

/// Methods that read a TorchScript model (the model setting is ignored by the others).
bool uses_model(nhnet::Method m) { return m == nhnet::Method::NhNet; }

const char* const kOrientNames[] = {"auto", "keep", "none", "mst", "viewpoint"};

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
  if (p.options.method == nhnet::Method::Pca && !p.options.mfps.scales.empty())
    p.warnings << "scales are ignored by the pca method";
  if (!s.model.isEmpty() && !uses_model(p.options.method))
    p.warnings << QString("model file ignored: method %1 uses no model").arg(s.method);
  if (uses_model(p.options.method))
    p.options.model.path = str(s.model.trimmed());  // empty = shipped
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

QString describe(const nhnet::EstimateResult& res, nhnet::Method method, Eigen::Index n) {
  return QString("%1 points, %2 failed, method %3, k %4, scales %5, noise ratio %6, %7 candidates")
      .arg(n)
      .arg(res.failed)
      .arg(nhnet::to_string(method))
      .arg(res.k_used)
      .arg(join(res.scales_used))
      .arg(res.noise_ratio, 0, 'g', 3)
      .arg(res.candidates);
}

}  // namespace

NormalsSettings::NormalsSettings()
    : method(nhnet::to_string(nhnet::EstimateOptions{}.method)),
      threads(nhnet::EstimateOptions{}.run.threads) {}

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

QStringList orient_names() {
  QStringList out;
  for (const char* n : kOrientNames) out << n;
  return out;
}

Orient orient_from_string(const QString& name) {
  const int i = orient_names().indexOf(name.trimmed().toLower());
  if (i < 0)
    throw nhnet::InvalidOptions("unknown orientation '" + str(name) + "' (expected " +
                                str(orient_names().join(", ")) + ")");
  return Orient(i);
}

bool method_uses_model(const QString& name) {
  for (nhnet::Method m : kMethods)
    if (name.trimmed().compare(nhnet::to_string(m), Qt::CaseInsensitive) == 0) return uses_model(m);
  return false;
}

bool denoise_available() { return NHNET_CC_HAS_DENOISE != 0; }

Outcome estimate_cloud_normals(ccPointCloud& cloud, const NormalsSettings& settings,
                               ccProgressDialog* dialog) {
  Prepared p = prepare(settings);
  Outcome out;
  out.warnings = p.warnings;
  nhnet::OrientOptions orient;
  orient.run.threads = settings.threads;
  orient.viewpoint =
      Eigen::Vector3d(settings.viewpoint[0], settings.viewpoint[1], settings.viewpoint[2]);
  switch (settings.orient) {
    case Orient::Auto:
      orient.mode = cloud.hasNormals() ? nhnet::OrientMode::Keep : nhnet::OrientMode::Mst;
      break;
    case Orient::Keep: orient.mode = nhnet::OrientMode::Keep; break;
    case Orient::None: orient.mode = nhnet::OrientMode::None; break;
    case Orient::Mst: orient.mode = nhnet::OrientMode::Mst; break;
    case Orient::Viewpoint: orient.mode = nhnet::OrientMode::Viewpoint; break;
  }
  if (orient.mode == nhnet::OrientMode::Keep && !cloud.hasNormals()) {
    out.warnings << "orientation keep: the cloud has no normals, so the signs stay arbitrary";
    orient.mode = nhnet::OrientMode::None;
  }
  const bool orienting = orient.mode != nhnet::OrientMode::None;

  const nhnet::Points pts = copy_points(cloud);
  const nhnet::Normals reference =
      orient.mode == nhnet::OrientMode::Keep ? copy_normals(cloud) : nhnet::Normals();
  nhnet::EstimateResult res;
  nhnet::OrientResult ores;
  run_with_progress(dialog, [&](const nhnet::ProgressCallback& cb) {
    const double split = orienting ? 0.85 : 1.0;
    res = run_estimate(pts, p.options, narrow(cb, 0, split));
    if (!orienting) return;
    orient.run.progress = narrow(cb, split, 1);
    ores = nhnet::orient_normals(pts, res.normals, orient, reference);
  });
  out.warnings << to_qt(res.warnings);
  if (ores.unoriented > 0)
    out.warnings << QString("orientation %1: %2 normals could not be oriented (left as estimated)")
                        .arg(nhnet::to_string(orient.mode))
                        .arg(ores.unoriented);
  store_normals(cloud, res.normals);

  out.summary = describe(res, p.options.method, pts.rows()) +
                QString(", orient %1").arg(nhnet::to_string(orient.mode));
  if (orienting) out.summary += QString(" (%1 flipped").arg(ores.flipped);
  if (orient.mode == nhnet::OrientMode::Mst)
    out.summary += QString(", %1 components").arg(ores.components);
  if (orienting) out.summary += ")";
  return out;
}

Outcome denoise_cloud(ccPointCloud& cloud, const DenoiseSettings& settings,
                      ccProgressDialog* dialog) {
#if NHNET_CC_HAS_DENOISE
  if (settings.iterations < 1) throw nhnet::InvalidOptions("iterations must be >= 1");
  if (!(settings.radius >= 0) || !std::isfinite(settings.radius))
    throw nhnet::InvalidOptions("radius must be >= 0 (0 = chosen from the point spacing)");
  Outcome out;
  QString which = settings.normals.trimmed().toLower();
  if (which == "auto") which = cloud.hasNormals() ? QString("input") : method_names().front();
  const bool from_input = which == "input";
  Prepared p;
  if (!from_input) {
    NormalsSettings es = settings.estimate;
    es.method = which;
    es.orient = Orient::None;  // the denoiser does not need signs
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
  run_with_progress(dialog, [&](const nhnet::ProgressCallback& cb) {
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
  (void)dialog;
  throw nhnet::InvalidOptions(
      "normal-guided denoise is not in this build of nhnet: the core's denoise stage "
      "(nhnet/denoise/denoise.hpp) was not found when the plugin was built");
#endif
}

void run_with_progress(ccProgressDialog* dialog,
                       const std::function<void(const nhnet::ProgressCallback&)>& work) {
  if (!dialog) {
    work(nhnet::ProgressCallback());
    return;
  }
  std::atomic<bool> cancel{false};
  std::mutex mutex;
  double fraction = 0;
  std::string stage;
  const nhnet::ProgressCallback cb = [&](double f, const std::string& s) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      fraction = f;
      stage = s;
    }
    return !cancel.load();
  };
  // Modal: while the worker runs, nothing else in CloudCompare can delete or edit the cloud.
  dialog->setWindowModality(Qt::ApplicationModal);
  dialog->setRange(0, 100);
  dialog->setValue(0);
  dialog->show();
  QCoreApplication::processEvents();
  std::future<void> done = std::async(std::launch::async, [&] { work(cb); });
  std::string shown;
  while (done.wait_for(std::chrono::milliseconds(30)) != std::future_status::ready) {
    double f;
    std::string s;
    {
      std::lock_guard<std::mutex> lock(mutex);
      f = fraction;
      s = stage;
    }
    if (s != shown) {
      dialog->setInfo(QString::fromStdString(s));
      shown = s;
    }
    if (!cancel.load()) dialog->setValue(int(std::lround(100 * std::clamp(f, 0.0, 1.0))));
    QCoreApplication::processEvents();
    if (dialog->wasCanceled()) cancel = true;
  }
  dialog->stop();
  done.get();  // rethrows the worker's exception (nhnet::Cancelled after a cancel)
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
