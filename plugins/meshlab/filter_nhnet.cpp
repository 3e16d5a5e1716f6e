// MeshLab filter plugin: see filter_nhnet.h. Every exception of the core (and any other) is
// caught in applyFilter and turned into MeshLab's error message plus a log line; the mesh is
// only written to after the core call succeeded, so a failed run leaves it untouched.
#include "filter_nhnet.h"

#include "nhnet/errors.hpp"
#include "nhnet/estimate.hpp"

#include <array>
#include <new>
#include <string>
#include <vector>

namespace {

// The estimators offered, in menu order (the first is the default). A method the core gains
// is one more entry here.
constexpr std::array<nhnet::Method, 2> kMethods{nhnet::Method::Mfps, nhnet::Method::Pca};

// Orientation choices, in menu order (the first is the default).
enum class Orientation { Keep, None };
constexpr std::array<Orientation, 2> kOrientations{Orientation::Keep, Orientation::None};

QString method_label(nhnet::Method m) {
  switch (m) {
    case nhnet::Method::Mfps:
      return "MFPS (PCA + multi-scale patch selection near features)";
    case nhnet::Method::Pca:
      return "PCA";
  }
  return nhnet::to_string(m);
}

QString orientation_label(Orientation o) {
  switch (o) {
    case Orientation::Keep:
      return "keep: agree with the current vertex normals";
    case Orientation::None:
      return "none: arbitrary sign";
  }
  return "?";
}

template <typename T, size_t N, typename F>
QStringList labels(const std::array<T, N>& items, F label) {
  QStringList l;
  for (const T& item : items) l << label(item);
  return l;
}

template <typename T, size_t N>
T choice(const std::array<T, N>& items, const RichParameterList& par, const char* name) {
  const int i = par.getEnum(name);
  if (i < 0 || size_t(i) >= N)
    throw nhnet::InvalidOptions(std::string("parameter '") + name + "': choice " +
                                std::to_string(i) + " out of range 0.." + std::to_string(N - 1));
  return items[size_t(i)];
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

}  // namespace

NhnetFilterPlugin::NhnetFilterPlugin() {
  typeList << FP_ESTIMATE_NORMALS;
  for (FilterIDType t : types()) actionList << new QAction(filterName(t), this);
}

QString NhnetFilterPlugin::pluginName() const { return "FilterNhnet"; }

QString NhnetFilterPlugin::filterName(FilterIDType filter) const {
  switch (filter) {
    case FP_ESTIMATE_NORMALS:
      return "Estimate normals (NH-Net)";
  }
  return "";
}

QString NhnetFilterPlugin::filterInfo(FilterIDType filter) const {
  switch (filter) {
    case FP_ESTIMATE_NORMALS:
      return "Estimates a unit normal for every vertex (point sets and mesh vertices alike; "
             "faces are ignored) with nhnet, which keeps sharp edges and corners of noisy scans "
             "where plain PCA rounds them off. <b>MFPS</b>: PCA for smooth points and "
             "multi-scale fitting patch selection near sharp features, with neighbourhood sizes "
             "chosen from the cloud's own noise level. Points whose normal cannot be computed "
             "get a zero normal (counted in the log).<br><br>"
             "See: <i>Haoran Zhou, Honghua Chen, Yidan Feng, Qiong Wang, Jing Qin, Haoran Xie, "
             "Fu Lee Wang, Mingqiang Wei, Jun Wang</i><br>"
             "<b>\"Geometry and Learning Co-supported Normal Estimation for Unstructured Point "
             "Cloud\"</b><br>CVPR 2020.";
  }
  return "";
}

NhnetFilterPlugin::FilterClass NhnetFilterPlugin::getClass(QAction*) {
  // Not Generic: MeshLab 2020.09 refuses to load Generic filters.
  return FilterClass(MeshFilterInterface::Normal | MeshFilterInterface::PointSet);
}

MeshFilterInterface::FILTER_ARITY NhnetFilterPlugin::filterArity(QAction*) const {
  return SINGLE_MESH;
}

int NhnetFilterPlugin::getPreConditions(QAction*) const { return MeshModel::MM_NONE; }

int NhnetFilterPlugin::postCondition(QAction*) const { return MeshModel::MM_VERTNORMAL; }

void NhnetFilterPlugin::initParameterSet(QAction* action, MeshModel&, RichParameterList& par) {
  const nhnet::EstimateOptions d;  // the core's defaults
  switch (ID(action)) {
    case FP_ESTIMATE_NORMALS:
      par.addParam(RichEnum("method", 0, labels(kMethods, method_label), "Method",
                            "MFPS: PCA for smooth points, multi-scale fitting patch selection "
                            "near sharp features (paper Sec. 4). PCA: plain PCA over the k "
                            "nearest neighbours."));
      par.addParam(RichInt("k", d.k, "PCA neighbours (0 = auto)",
                           "Neighbourhood size of PCA (self included), an integer >= 3; 0 = "
                           "chosen from the estimated noise level."));
      par.addParam(RichString("scales", "auto", "MFPS scales",
                              "MFPS patch sizes, e.g. 50,100,150 (the paper's), integers >= 4; "
                              "'auto' = chosen from the estimated noise level. Ignored by PCA."));
      par.addParam(RichEnum("orientation", 0, labels(kOrientations, orientation_label),
                            "Orientation",
                            "keep: flip each normal to agree with the vertex's current normal "
                            "(vertices with a zero normal keep an arbitrary sign). none: the "
                            "sign of each normal is arbitrary."));
      par.addParam(RichInt("threads", d.run.threads, "Threads (0 = all cores)",
                           "Worker threads; 0 = all cores. Results do not depend on it."));
      par.addParam(RichInt("seed", int(d.seed), "Random seed",
                           "Seed of MFPS's random plane samples (results are deterministic for "
                           "a seed)."));
      break;
  }
}

void NhnetFilterPlugin::fail(const QString& message) {
  errorMessage = "NH-Net: " + message;
  Log(GLLogStream::WARNING, errorMessage.toStdString());
}

bool NhnetFilterPlugin::applyFilter(QAction* action, MeshDocument& md,
                                    const RichParameterList& par, vcg::CallBackPos* cb) {
  errorMessage.clear();
  try {
    MeshModel* mm = md.mm();
    if (mm == nullptr) throw nhnet::UnprocessableInput("no current mesh layer");
    run(ID(action), *mm, par, cb);
    return true;
  } catch (const nhnet::InvalidOptions& e) {
    fail(QString("bad parameter: ") + e.what());
  } catch (const nhnet::UnprocessableInput& e) {
    fail(QString("cannot process this layer: ") + e.what());
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

void NhnetFilterPlugin::run(int id, MeshModel& mm, const RichParameterList& par,
                            vcg::CallBackPos* cb) {
  CMeshO& m = mm.cm;

  // Options first: a bad parameter fails before any work.
  nhnet::EstimateOptions opt;
  opt.method = choice(kMethods, par, "method");
  opt.k = par.getInt("k");
  opt.scales = scales_from(par.getString("scales"));
  const Orientation orientation = choice(kOrientations, par, "orientation");
  opt.run.threads = non_negative(par, "threads");
  opt.seed = uint64_t(non_negative(par, "seed"));
  if (cb != nullptr) {
    opt.run.progress = [cb](double fraction, const std::string& stage) {
      return cb(int(fraction * 100.0), stage.c_str());
    };
  }

  // Copy in: live (not deleted) vertices, in order.
  std::vector<CMeshO::VertexPointer> verts;
  verts.reserve(m.vert.size());
  for (auto& v : m.vert)
    if (!v.IsD()) verts.push_back(&v);
  nhnet::Points points(Eigen::Index(verts.size()), 3);
  nhnet::Normals current(Eigen::Index(verts.size()), 3);
  for (size_t i = 0; i < verts.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      points(Eigen::Index(i), c) = double(verts[i]->P()[c]);
      current(Eigen::Index(i), c) = double(verts[i]->N()[c]);
    }

  nhnet::EstimateResult res = nhnet::estimate_normals(points, opt);
  if (orientation == Orientation::Keep) nhnet::orient_like(res.normals, current);
  (void)id;

  // Copy out: failed points get a zero normal (MeshLab's "no normal").
  for (size_t i = 0; i < verts.size(); ++i) {
    const auto row = res.normals.row(Eigen::Index(i));
    const bool ok = res.valid[i] != 0;
    verts[i]->N() = ok ? Point3m(Scalarm(row(0)), Scalarm(row(1)), Scalarm(row(2)))
                       : Point3m(0, 0, 0);
  }
  mm.updateDataMask(MeshModel::MM_VERTNORMAL);

  for (const std::string& w : res.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
  QStringList scales;
  for (int v : res.scales_used) scales << QString::number(v);
  Log("NH-Net: normals of %d vertices (%lld failed), method %s, k %d, scales %s, noise ratio "
      "%.3g, %lld feature candidates",
      int(verts.size()), (long long)res.failed, nhnet::to_string(opt.method), res.k_used,
      scales.isEmpty() ? "-" : qUtf8Printable(scales.join("/")), res.noise_ratio,
      (long long)res.candidates);
}

MESHLAB_PLUGIN_NAME_EXPORTER(NhnetFilterPlugin)
