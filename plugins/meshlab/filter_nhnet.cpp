// MeshLab filter plugin: see filter_nhnet.h. Every exception of the core (and any other) is
// caught in applyFilter and turned into MeshLab's error message plus a log line; the mesh is
// only written to after the core call succeeded, so a failed run leaves it untouched.
#include "filter_nhnet.h"

#include "../common/polled_run.hpp"
#include "../common/precision_list.hpp"
#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/io/cloud.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"

#include <QApplication>
#include <QMainWindow>
#include <QProgressDialog>

#include <chrono>
#include <memory>
#include <new>
#include <string>
#include <vector>

namespace {

// A menu choice: the value and its label.
template <typename T>
struct Choice {
  T value;
  const char* label;
};

/// Lowest vertex quality of a computed normal with the confidence on (Screened Poisson drops
/// normals scaled to zero).
constexpr double kMinQuality = 1e-3;

// The estimators offered, in menu order (default: the core's, nhnet::default_method()). A method
// the core gains is one more line here.
const Choice<nhnet::Method> kMethods[] = {
    {nhnet::Method::Mfps, "MFPS (PCA + multi-scale patch selection near features)"},
    {nhnet::Method::Pca, "PCA"},
    {nhnet::Method::NhNet, "NH-Net (MFPS refined by the learned model; slower)"},
};

// Orientation choices, in menu order (scripts name them by index: new ones go at the end).
// Default: the core's, auto (nhnet::resolve_orientation: the current vertex normals, else the
// mesh's camera, else MST).
const Choice<nhnet::OrientMode> kOrientations[] = {
    {nhnet::OrientMode::Keep, "keep: agree with the current vertex normals"},
    {nhnet::OrientMode::Viewpoint, "viewpoint: towards the viewpoint below"},
    {nhnet::OrientMode::Mst, "MST: propagated over the neighbour graph (Hoppe 1992)"},
    {nhnet::OrientMode::None, "none: arbitrary sign"},
    {nhnet::OrientMode::Auto, "auto: vertex normals, else the mesh's camera, else MST"},
    {nhnet::OrientMode::Up, "up: facing +z (airborne scans)"},
};

// Which normals guide the denoiser, in menu order (the first is the default).
enum class GuideNormals { Current, Estimate };
const Choice<GuideNormals> kGuides[] = {
    {GuideNormals::Current, "current vertex normals"},
    {GuideNormals::Estimate, "estimate first (the default method, automatic scales)"},
};

template <typename T, size_t N>
QStringList labels(const Choice<T> (&choices)[N]) {
  QStringList l;
  for (const Choice<T>& c : choices) l << c.label;
  return l;
}

template <typename T, size_t N>
int index_of(const Choice<T> (&choices)[N], T value) {
  for (size_t i = 0; i < N; ++i)
    if (choices[i].value == value) return int(i);
  return 0;
}

// The index chosen in enum parameter `name` of `count` entries; throws when out of range.
size_t enum_index(const RichParameterList& par, const char* name, size_t count) {
  const int i = par.getEnum(name);
  if (i < 0 || size_t(i) >= count)
    throw nhnet::InvalidOptions(std::string("parameter '") + name + "': choice " +
                                std::to_string(i) + " out of range 0.." +
                                std::to_string(count - 1));
  return size_t(i);
}

template <typename T, size_t N>
T choice(const Choice<T> (&choices)[N], const RichParameterList& par, const char* name) {
  return choices[enum_index(par, name, N)].value;
}

// The network's precisions (nhnet::kPrecisions, the core's one list, its default first), in
// menu order; scripts name them by index.
int precision_index(const std::string& precision) {
  for (size_t i = 0; i < nhnet::kPrecisions.size(); ++i)
    if (precision == nhnet::kPrecisions[i]) return int(i);
  return 0;
}

// The "precision" parameter of both filters; `use` ends its help with when the network runs.
RichEnum precision_param(const std::string& value, const QString& use) {
  return RichEnum("precision", precision_index(value), nhplugin::precision_list(),
                  "NH-Net precision", nhplugin::precision_help() + " " + use);
}

std::string precision_choice(const RichParameterList& par) {
  return nhnet::kPrecisions[enum_index(par, "precision", nhnet::kPrecisions.size())];
}

int non_negative(const RichParameterList& par, const char* name) {
  const int v = par.getInt(name);
  if (v < 0)
    throw nhnet::InvalidOptions(std::string("parameter '") + name + "' must be >= 0, got " +
                                std::to_string(v));
  return v;
}

// "auto" or empty -> {} (chosen from the noise level); "50,100,150" -> {50, 100, 150}. The core
// checks the range of each value.
// scales_from's inverse: {} -> "auto", {50, 100, 150} -> "50,100,150".
QString scales_text(const std::vector<int>& scales) {
  QStringList s;
  for (int v : scales) s << QString::number(v);
  return s.isEmpty() ? QString("auto") : s.join(",");
}

std::vector<int> scales_from(const QString& text) {
  const QString t = text.trimmed();
  if (t.isEmpty() || t.compare("auto", Qt::CaseInsensitive) == 0) return {};
  std::vector<int> scales;
  for (const QString& item : t.split(',')) {
    bool ok = false;
    const int v = item.trimmed().toInt(&ok);
    if (!ok)
      throw nhnet::InvalidOptions("parameter 'scales': '" + text.toStdString() +
                                  "' is not 'auto' or a comma-separated list of integers "
                                  "such as 50,100,150");
    scales.push_back(v);
  }
  return scales;
}

// In the MeshLab GUI (a visible main window), a modal progress dialog with a Cancel button:
// MeshLab's own progress bar has none. Null in meshlabserver.
std::unique_ptr<QProgressDialog> cancel_dialog() {
  if (qobject_cast<QApplication*>(QCoreApplication::instance()) == nullptr) return nullptr;
  for (QWidget* w : QApplication::topLevelWidgets())
    if (qobject_cast<QMainWindow*>(w) != nullptr && w->isVisible()) {
      auto d = std::make_unique<QProgressDialog>("NH-Net", "Cancel", 0, 100, w);
      d->setWindowModality(Qt::ApplicationModal);  // nothing can edit the mesh meanwhile
      d->setMinimumDuration(500);
      return d;
    }
  return nullptr;
}

// One poll of a run (host thread): MeshLab's callback when the percentage changes (false =
// cancel, vcg's convention), the dialog's Cancel, the NHNET_PLUGIN_CANCEL_AT test hook.
struct Poller {
  vcg::CallBackPos* cb;
  QProgressDialog* dialog;
  double cancel_at = nhplugin::test_cancel_at();
  int shown = -1;

  bool operator()(double f, const std::string& stage) {
    const int percent = int(f * 100.0);
    bool go = f < cancel_at;
    if (cb != nullptr && percent != shown) go = cb(percent, stage.c_str()) && go;
    shown = percent;
    if (dialog != nullptr) {
      dialog->setLabelText(QString::fromStdString(stage));
      dialog->setValue(percent);
      QCoreApplication::processEvents();
      go = go && !dialog->wasCanceled();
    }
    return go;
  }
};

bool has_vertex_normals(const CMeshO& m) {
  for (const auto& v : m.vert)
    if (!v.IsD() && v.N() != Point3m(0, 0, 0)) return true;
  return false;
}

// The live (not deleted) vertices of a mesh in order, with their positions and normals.
struct Vertices {
  std::vector<CMeshO::VertexPointer> ptr;
  nhnet::Points points;
  nhnet::Normals normals;
};

Vertices copy_in(CMeshO& m) {
  Vertices v;
  v.ptr.reserve(m.vert.size());
  for (auto& vert : m.vert)
    if (!vert.IsD()) v.ptr.push_back(&vert);
  const auto n = Eigen::Index(v.ptr.size());
  v.points.resize(n, 3);
  v.normals.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      v.points(i, c) = double(v.ptr[size_t(i)]->P()[c]);
      v.normals(i, c) = double(v.ptr[size_t(i)]->N()[c]);
    }
  return v;
}

Point3m point3m(const nhnet::Points& rows, Eigen::Index i) {
  return Point3m(Scalarm(rows(i, 0)), Scalarm(rows(i, 1)), Scalarm(rows(i, 2)));
}

// The mesh's camera (cm.shot: the PLY camera element, or set in MeshLab), when it is set.
void add_shot_sensor(const CMeshO& m, nhnet::Cloud& cloud) {
  if (!m.shot.IsValid()) return;
  nhnet::Sensor s;
  const auto t = m.shot.Extrinsics.Tra();
  s.position = Eigen::Vector3d(t[0], t[1], t[2]);
  const auto r = m.shot.Extrinsics.Rot();  // rows: the camera's axes
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s.rotation(j, i) = double(r[i][j]);
  s.source = "the mesh's camera";
  cloud.sensors.push_back(s);
}

QString join(const std::vector<int>& values) {
  QStringList s;
  for (int v : values) s << QString::number(v);
  return s.isEmpty() ? QString("-") : s.join("/");
}

}  // namespace

NhnetFilterPlugin::NhnetFilterPlugin() {
  typeList << FP_ESTIMATE_NORMALS << FP_DENOISE;
  for (FilterIDType t : types()) actionList << new QAction(filterName(t), this);
}

QString NhnetFilterPlugin::pluginName() const { return "FilterNhnet"; }

QString NhnetFilterPlugin::filterName(FilterIDType filter) const {
  switch (filter) {
    case FP_ESTIMATE_NORMALS: return "Estimate normals (NH-Net)";
    case FP_DENOISE: return "Normal-guided denoise";
  }
  return "";
}

QString NhnetFilterPlugin::filterInfo(FilterIDType filter) const {
  const QString cite =
      "<br><br>See: <b>\"Geometry and Learning Co-supported Normal Estimation for Unstructured "
      "Point Cloud\"</b>, CVPR 2020.";
  switch (filter) {
    case FP_ESTIMATE_NORMALS:
      return "Estimates a unit normal for every vertex (point sets and mesh vertices alike; "
             "faces are ignored) with nhnet, which keeps sharp edges and corners of noisy scans "
             "where plain PCA rounds them off. <b>MFPS</b>: PCA for smooth points and "
             "multi-scale fitting patch selection near sharp features, with neighbourhood sizes "
             "chosen from the cloud's own noise level. Points whose normal cannot be computed "
             "get a zero normal (counted in the log)." +
             cite;
    case FP_DENOISE:
      return "Moves every vertex towards the surface its neighbours' normals describe (paper "
             "Sec. 7, Eq. 9): along the normal on smooth parts, onto the edge line near sharp "
             "edges, with neighbourhoods fixed over the iterations so points do not pile up. "
             "Guided by the current vertex normals (their sign does not matter) or by normals "
             "estimated first with the default method (then also stored as the vertex normals). "
             "Vertices "
             "without a usable normal stay in place." +
             cite;
  }
  return "";
}

NhnetFilterPlugin::FilterClass NhnetFilterPlugin::getClass(QAction* action) {
  // Never Generic: MeshLab 2020.09 refuses to load Generic filters.
  if (ID(action) == FP_DENOISE)
    return FilterClass(MeshFilterInterface::Smoothing | MeshFilterInterface::PointSet);
  return FilterClass(MeshFilterInterface::Normal | MeshFilterInterface::PointSet);
}

MeshFilterInterface::FILTER_ARITY NhnetFilterPlugin::filterArity(QAction*) const {
  return SINGLE_MESH;
}

int NhnetFilterPlugin::getPreConditions(QAction*) const { return MeshModel::MM_NONE; }

int NhnetFilterPlugin::postCondition(QAction* action) const {
  if (ID(action) == FP_DENOISE)
    return MeshModel::MM_VERTCOORD | MeshModel::MM_VERTNORMAL | MeshModel::MM_FACENORMAL;
  return MeshModel::MM_VERTNORMAL | MeshModel::MM_VERTQUALITY;
}

void NhnetFilterPlugin::initParameterSet(QAction* action, MeshModel& m, RichParameterList& par) {
  const nhnet::EstimateOptions e;  // the core's defaults
  const nhnet::OrientOptions o;
  const nhnet::DenoiseOptions d;
  // The mesh's camera, when set, is the viewpoint's default (as in MeshLab's "Compute normals
  // for point sets").
  const Eigen::Vector3d vp = m.cm.shot.IsValid() ? Eigen::Vector3d(m.cm.shot.Extrinsics.Tra()[0],
                                                                   m.cm.shot.Extrinsics.Tra()[1],
                                                                   m.cm.shot.Extrinsics.Tra()[2])
                                                 : o.viewpoint;
  switch (ID(action)) {
    case FP_ESTIMATE_NORMALS:
      par.addParam(RichEnum("method", index_of(kMethods, nhnet::default_method()), labels(kMethods),
                            "Method",
                            "MFPS: PCA for smooth points, multi-scale fitting patch selection "
                            "near sharp features (paper Sec. 4). PCA: plain PCA over the k "
                            "nearest neighbours. NH-Net: MFPS refined by the learned model "
                            "(paper Sec. 5; several times slower). Default: NH-Net when its "
                            "model is installed, else MFPS (as nhnet-cli)."));
      par.addParam(RichInt("k", e.k, "PCA neighbours (0 = auto)",
                           "Neighbourhood size of PCA (self included), an integer >= 3; 0 = "
                           "chosen from the estimated noise level."));
      par.addParam(RichString("scales", scales_text(e.mfps.scales), "MFPS scales",
                              "MFPS patch sizes, e.g. 50,100,150 (the paper's), integers >= 4; "
                              "'auto' = chosen from the estimated noise level. Ignored by PCA."));
      par.addParam(RichEnum("orientation", index_of(kOrientations, nhnet::kDefaultOrientMode),
                            labels(kOrientations), "Orientation",
                            "auto (default): keep when the vertices have normals, else towards "
                            "the mesh's camera when it is set (a PLY camera element), else MST. "
                            "up: facing +z where the surface is not vertical. keep: flip each "
                            "normal to agree with the vertex's current normal "
                            "(vertices with a zero normal keep an arbitrary sign). viewpoint: "
                            "point towards the viewpoint (the scanner's position). MST: one "
                            "consistent side per connected part, propagated over a minimum "
                            "spanning tree of the k-nearest-neighbour graph from the part's "
                            "highest point, turned up (outwards on closed surfaces). none: the "
                            "sign of each normal is arbitrary."));
      par.addParam(RichPoint3f(
          "viewpoint", vcg::Point3f(float(vp.x()), float(vp.y()), float(vp.z())), "Viewpoint",
          "Sensor position for 'viewpoint' orientation, in the mesh's "
          "coordinates (default: the mesh's camera when set)."));
      par.addParam(RichInt("mst_k", o.k, "MST neighbours",
                           "Neighbours per point (self included, >= 2) of the graph 'MST' "
                           "orientation propagates over."));
      par.addParam(RichInt("threads", e.run.threads, "Threads (0 = all cores)",
                           "Worker threads; 0 = all cores. Results do not depend on it."));
      par.addParam(RichInt("seed", int(e.mfps.seed), "Random seed",
                           "Seed of MFPS's random plane samples (results are deterministic for "
                           "a seed)."));
      par.addParam(RichString("model", QString::fromStdString(e.model.path), "NH-Net model file",
                              "TorchScript model written by nhnet-export; empty = the shipped "
                              "model installed with nhnet. Used by the NH-Net method only."));
      par.addParam(precision_param(e.model.precision, "Used by the NH-Net method only."));
      par.addParam(RichBool("confidence", nhnet::kPluginConfidence, "Confidence as vertex quality",
                            "Store each normal's confidence in [0, 1] (the chance that it is "
                            "within 30 degrees of the true normal, judged from its "
                            "neighbourhood) as vertex quality, at least 0.001 where a normal "
                            "was computed: Screened Poisson's 'confidence' option then weighs "
                            "each normal by it. Off: the quality is left as it was."));
      break;
    case FP_DENOISE:
      par.addParam(
          RichInt("iterations", d.iterations, "Iterations", "Update steps (the paper's: 20)."));
      par.addParam(RichFloat("radius", float(d.radius), "Radius (0 = auto)",
                             "Ball radius of the neighbourhoods, in the mesh's units; 0 = " +
                                 QString::number(d.radius_factor) +
                                 " x the average point spacing."));
      par.addParam(RichEnum("normals", 0, labels(kGuides), "Normals",
                            "Which normals guide the update: the current vertex normals, or "
                            "normals estimated first with the default method (NH-Net when its "
                            "model is installed, else MFPS) and automatic scales (stored as the "
                            "vertex normals)."));
      par.addParam(RichInt("threads", d.run.threads, "Threads (0 = all cores)",
                           "Worker threads; 0 = all cores."));
      par.addParam(precision_param(e.model.precision,
                                   "Used when the normals are estimated first by NH-Net."));
      break;
  }
}

void NhnetFilterPlugin::fail(const QString& message) {
  errorMessage = "NH-Net: " + message;
  Log(GLLogStream::WARNING, errorMessage.toStdString());
}

bool NhnetFilterPlugin::applyFilter(QAction* action, MeshDocument& md, const RichParameterList& par,
                                    vcg::CallBackPos* cb) {
  errorMessage.clear();
  try {
    MeshModel* mm = md.mm();
    if (mm == nullptr) throw nhnet::UnprocessableInput("no current mesh layer");
    switch (ID(action)) {
      case FP_ESTIMATE_NORMALS: estimate(*mm, par, cb); break;
      case FP_DENOISE: denoise(*mm, par, cb); break;
      default: throw std::logic_error("unknown filter " + action->text().toStdString());
    }
    return true;
  } catch (const nhnet::InvalidOptions& e) {
    fail(QString("bad parameter: ") + e.what());
  } catch (const nhnet::UnprocessableInput& e) {
    fail(QString("cannot process this layer: ") + e.what());
  } catch (const nhnet::ModelError& e) {
    fail(QString("bad NH-Net model: ") + e.what());
  } catch (const nhnet::Cancelled&) {
    fail("cancelled; the layer was left unchanged");
  } catch (const std::bad_alloc&) {
    fail("out of memory; the layer was left unchanged");
  } catch (const std::exception& e) {
    fail(QString("internal error (please report it): ") + e.what());
  } catch (...) {
    fail("internal error (please report it): unknown exception");
  }
  return false;
}

void NhnetFilterPlugin::runPolled(vcg::CallBackPos* cb,
                                  const std::function<void(const nhnet::ProgressCallback&)>& work) {
  const std::unique_ptr<QProgressDialog> dialog = cancel_dialog();
  Poller poller{cb, dialog.get()};
  using Clock = std::chrono::steady_clock;
  Clock::time_point asked;
  try {
    nhplugin::run_polled(work, [&](double f, const std::string& stage) {
      const bool go = poller(f, stage);
      if (!go) asked = Clock::now();
      return go;
    });
  } catch (const nhnet::Cancelled&) {
    const std::chrono::duration<double> delay = Clock::now() - asked;
    Log("NH-Net: stopped %.2f s after the cancel", delay.count());
    throw;
  }
}

// The filter's estimate options; a bad parameter throws before any work.
nhnet::EstimateOptions NhnetFilterPlugin::estimateOptions(const RichParameterList& par) {
  nhnet::EstimateOptions opt;
  opt.method = choice(kMethods, par, "method");
  opt.k = par.getInt("k");
  opt.mfps.scales = scales_from(par.getString("scales"));
  opt.run.threads = non_negative(par, "threads");
  opt.mfps.seed = uint64_t(non_negative(par, "seed"));
  if (opt.method == nhnet::Method::NhNet) {
    opt.model.path = par.getString("model").trimmed().toStdString();
    opt.model.precision = precision_choice(par);
  }
  opt.confidence = par.getBool("confidence");
  std::string why;
  if (opt.method == nhnet::default_method(&why) && !why.empty())
    Log(GLLogStream::WARNING, "NH-Net: method %s (%s; method NH-Net needs it)",
        nhnet::to_string(opt.method), why.c_str());
  return opt;
}

// The orientation asked for, made concrete for this layer (auto: nhnet::resolve_orientation
// on what the layer carries: its vertex normals, its camera).
nhnet::OrientPlan NhnetFilterPlugin::orientPlan(const RichParameterList& par,
                                                const nhnet::Cloud& cloud) {
  nhnet::OrientOptions requested;
  requested.mode = choice(kOrientations, par, "orientation");
  const vcg::Point3f vp = par.getPoint3f("viewpoint");
  requested.viewpoint = Eigen::Vector3d(vp[0], vp[1], vp[2]);
  requested.k = par.getInt("mst_k");
  requested.run.threads = non_negative(par, "threads");
  nhnet::OrientPlan plan = nhnet::resolve_orientation(cloud, requested);
  if (plan.options.mode == nhnet::OrientMode::Keep && !cloud.has_normals()) {
    Log(GLLogStream::WARNING,
        "NH-Net: orientation keep: the vertices have no normals, so the "
        "signs stay arbitrary");
    plan.options.mode = nhnet::OrientMode::None;
  }
  return plan;
}

void NhnetFilterPlugin::estimate(MeshModel& mm, const RichParameterList& par,
                                 vcg::CallBackPos* cb) {
  const nhnet::EstimateOptions opt = estimateOptions(par);
  Vertices v = copy_in(mm.cm);
  nhnet::Cloud cloud;
  cloud.points = std::move(v.points);
  if (has_vertex_normals(mm.cm)) cloud.normals = std::move(v.normals);
  v.normals = nhnet::Normals();  // zeros otherwise: not kept through the run
  add_shot_sensor(mm.cm, cloud);
  const nhnet::OrientPlan plan = orientPlan(par, cloud);

  nhnet::OrientedResult both;
  runPolled(cb, [&](const nhnet::ProgressCallback& progress) {
    both = nhnet::estimate_oriented(cloud.points, opt, plan.options,
                                    nhnet::RunContext{opt.run.threads, progress}, cloud.normals);
  });
  const nhnet::EstimateResult& res = both.estimate;
  const nhnet::OrientResult& ores = both.orient;

  // Copy out: failed points get a zero normal (MeshLab's "no normal").
  for (size_t i = 0; i < v.ptr.size(); ++i)
    v.ptr[i]->N() = res.valid[i] ? point3m(res.normals, Eigen::Index(i)) : Point3m(0, 0, 0);
  mm.updateDataMask(MeshModel::MM_VERTNORMAL);
  if (opt.confidence) {
    // Screened Poisson multiplies each normal by its quality and drops zero normals: a computed
    // normal keeps a floor of 0.001, a failed one (zero normal) gets 0.
    for (size_t i = 0; i < v.ptr.size(); ++i)
      v.ptr[i]->Q() = res.valid[i] ? std::max(res.confidence[Eigen::Index(i)], kMinQuality) : 0;
    mm.updateDataMask(MeshModel::MM_VERTQUALITY);
  }

  for (const std::string& w : res.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
  const std::string ran = nhnet::network_phrase(res.device_used, res.precision_used);
  Log("NH-Net: normals of %d vertices (%lld failed), method %s%s, k %d, scales %s, noise ratio "
      "%.3g, %lld feature candidates; orientation %s from %s: %lld flipped, %lld undecided",
      int(v.ptr.size()), (long long)res.failed, nhnet::to_string(opt.method), ran.c_str(),
      res.k_used, qUtf8Printable(join(res.scales_used)), res.noise_ratio, (long long)res.candidates,
      nhnet::to_string(plan.options.mode), plan.source.c_str(), (long long)ores.flipped,
      (long long)ores.unoriented);
}

void NhnetFilterPlugin::denoise(MeshModel& mm, const RichParameterList& par, vcg::CallBackPos* cb) {
  nhnet::DenoiseOptions opt;
  opt.iterations = par.getInt("iterations");
  opt.radius = double(par.getFloat("radius"));
  const GuideNormals guide = choice(kGuides, par, "normals");
  opt.run.threads = non_negative(par, "threads");

  Vertices v = copy_in(mm.cm);
  if (guide == GuideNormals::Current && v.normals.rows() > 0 &&
      v.normals.cwiseAbs().maxCoeff() == 0)
    throw nhnet::UnprocessableInput(
        "the vertices have no normals; choose 'estimate first' for Normals, or run "
        "'Estimate normals (NH-Net)' before");
  nhnet::EstimateOptions eopt;
  eopt.method = nhnet::default_method();
  eopt.run.threads = opt.run.threads;
  eopt.model.precision = precision_choice(par);
  nhnet::EstimateResult est;
  nhnet::DenoiseResult res;
  runPolled(cb, [&](const nhnet::ProgressCallback& progress) {
    const double split = guide == GuideNormals::Estimate ? 0.5 : 0.0;
    if (guide == GuideNormals::Estimate) {
      eopt.run.progress = [&](double f, const std::string& s) { return progress(f * split, s); };
      est = nhnet::estimate_normals(v.points, eopt);
      nhnet::orient_like(est.normals, v.normals);
      v.normals = est.normals;  // NaN rows (failed points) are skipped by the denoiser
    }
    opt.run.progress = [&](double f, const std::string& s) {
      return progress(split + (1 - split) * f, s);
    };
    res = nhnet::denoise_points(v.points, v.normals, opt);
  });
  for (const std::string& w : est.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
  if (guide == GuideNormals::Estimate)
    Log("NH-Net: guiding normals by method %s%s (%lld failed)", nhnet::to_string(eopt.method),
        nhnet::network_phrase(est.device_used, est.precision_used).c_str(), (long long)est.failed);

  for (size_t i = 0; i < v.ptr.size(); ++i) {
    const auto r = Eigen::Index(i);
    v.ptr[i]->P() = point3m(res.points, r);
    if (guide == GuideNormals::Estimate)
      v.ptr[i]->N() = v.normals.row(r).allFinite() ? point3m(v.normals, r) : Point3m(0, 0, 0);
  }
  if (mm.cm.fn > 0) vcg::tri::UpdateNormal<CMeshO>::PerFaceNormalized(mm.cm);
  vcg::tri::UpdateBounding<CMeshO>::Box(mm.cm);

  for (const std::string& w : res.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
  Log("NH-Net: denoised %lld of %d vertices (%lld without a usable normal, %lld isolated), "
      "%d iterations, radius %.4g, %.1f neighbours on average",
      (long long)res.moved, int(v.ptr.size()), (long long)res.skipped, (long long)res.isolated,
      opt.iterations, res.radius, res.mean_neighbors);
}

MESHLAB_PLUGIN_NAME_EXPORTER(NhnetFilterPlugin)
