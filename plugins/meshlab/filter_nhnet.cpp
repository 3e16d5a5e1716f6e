// MeshLab filter plugin: see filter_nhnet.h. Every exception of the core (and any other) is
// caught in applyFilter and turned into MeshLab's error message plus a log line; the mesh is
// only written to after the core call succeeded, so a failed run leaves it untouched.
#include "filter_nhnet.h"

#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"

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

// The estimators offered, in menu order (the first is the default). A method the core gains
// is one more line here.
const Choice<nhnet::Method> kMethods[] = {
    {nhnet::Method::Mfps, "MFPS (PCA + multi-scale patch selection near features)"},
    {nhnet::Method::Pca, "PCA"},
    {nhnet::Method::NhNet, "NH-Net (MFPS refined by the learned model; slower)"},
};

// Orientation choices, in menu order. Default: keep when the layer has vertex normals (a mesh's
// face-based ones, or a cloud's loaded ones), else MST (the core's default).
const Choice<nhnet::OrientMode> kOrientations[] = {
    {nhnet::OrientMode::Keep, "keep: agree with the current vertex normals"},
    {nhnet::OrientMode::Viewpoint, "viewpoint: towards the viewpoint below"},
    {nhnet::OrientMode::Mst, "MST: propagated over the neighbour graph (Hoppe 1992)"},
    {nhnet::OrientMode::None, "none: arbitrary sign"},
};

// Which normals guide the denoiser, in menu order (the first is the default).
enum class GuideNormals { Current, Estimate };
const Choice<GuideNormals> kGuides[] = {
    {GuideNormals::Current, "current vertex normals"},
    {GuideNormals::Estimate, "estimate first (MFPS, automatic scales)"},
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

template <typename T, size_t N>
T choice(const Choice<T> (&choices)[N], const RichParameterList& par, const char* name) {
  const int i = par.getEnum(name);
  if (i < 0 || size_t(i) >= N)
    throw nhnet::InvalidOptions(std::string("parameter '") + name + "': choice " +
                                std::to_string(i) + " out of range 0.." + std::to_string(N - 1));
  return choices[i].value;
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

// MeshLab's progress callback (percent, message) as the core's; a false return cancels.
nhnet::ProgressCallback progress_of(vcg::CallBackPos* cb) {
  if (cb == nullptr) return {};
  return [cb](double fraction, const std::string& stage) {
    return cb(int(fraction * 100.0), stage.c_str());
  };
}

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
             "estimated first with MFPS (then also stored as the vertex normals). Vertices "
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
  return MeshModel::MM_VERTNORMAL;
}

void NhnetFilterPlugin::initParameterSet(QAction* action, MeshModel& m, RichParameterList& par) {
  const nhnet::EstimateOptions e;  // the core's defaults
  const nhnet::OrientOptions o;
  const nhnet::DenoiseOptions d;
  const nhnet::OrientMode orient_default =
      has_vertex_normals(m.cm) ? nhnet::OrientMode::Keep : o.mode;
  switch (ID(action)) {
    case FP_ESTIMATE_NORMALS:
      par.addParam(RichEnum("method", 0, labels(kMethods), "Method",
                            "MFPS: PCA for smooth points, multi-scale fitting patch selection "
                            "near sharp features (paper Sec. 4). PCA: plain PCA over the k "
                            "nearest neighbours. NH-Net: MFPS refined by the learned model "
                            "(paper Sec. 5; several times slower)."));
      par.addParam(RichInt("k", e.k, "PCA neighbours (0 = auto)",
                           "Neighbourhood size of PCA (self included), an integer >= 3; 0 = "
                           "chosen from the estimated noise level."));
      par.addParam(RichString("scales", "auto", "MFPS scales",
                              "MFPS patch sizes, e.g. 50,100,150 (the paper's), integers >= 4; "
                              "'auto' = chosen from the estimated noise level. Ignored by PCA."));
      par.addParam(RichEnum("orientation", index_of(kOrientations, orient_default),
                            labels(kOrientations), "Orientation",
                            "keep: flip each normal to agree with the vertex's current normal "
                            "(vertices with a zero normal keep an arbitrary sign). viewpoint: "
                            "point towards the viewpoint (the scanner's position). MST: one "
                            "consistent side per connected part, propagated over a minimum "
                            "spanning tree of the k-nearest-neighbour graph from the part's "
                            "highest point, turned up (outwards on closed surfaces). none: the "
                            "sign of each normal is arbitrary."));
      par.addParam(RichPoint3f(
          "viewpoint",
          vcg::Point3f(float(o.viewpoint.x()), float(o.viewpoint.y()), float(o.viewpoint.z())),
          "Viewpoint",
          "Sensor position for 'viewpoint' orientation, in the "
          "mesh's coordinates."));
      par.addParam(RichInt("mst_k", o.k, "MST neighbours",
                           "Neighbours per point (self included, >= 2) of the graph 'MST' "
                           "orientation propagates over."));
      par.addParam(RichInt("threads", e.run.threads, "Threads (0 = all cores)",
                           "Worker threads; 0 = all cores. Results do not depend on it."));
      par.addParam(RichInt("seed", int(e.mfps.seed), "Random seed",
                           "Seed of MFPS's random plane samples (results are deterministic for "
                           "a seed)."));
      par.addParam(RichString("model", "", "NH-Net model file",
                              "TorchScript model written by nhnet-export; empty = the shipped "
                              "model installed with nhnet. Used by the NH-Net method only."));
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
                            "normals estimated first with MFPS and automatic scales (stored "
                            "as the vertex normals)."));
      par.addParam(RichInt("threads", d.run.threads, "Threads (0 = all cores)",
                           "Worker threads; 0 = all cores."));
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

void NhnetFilterPlugin::estimate(MeshModel& mm, const RichParameterList& par,
                                 vcg::CallBackPos* cb) {
  // Options first: a bad parameter fails before any work.
  nhnet::EstimateOptions opt;
  opt.method = choice(kMethods, par, "method");
  opt.k = par.getInt("k");
  opt.mfps.scales = scales_from(par.getString("scales"));
  nhnet::OrientOptions oopt;
  oopt.mode = choice(kOrientations, par, "orientation");
  const vcg::Point3f vp = par.getPoint3f("viewpoint");
  oopt.viewpoint = Eigen::Vector3d(vp[0], vp[1], vp[2]);
  oopt.k = par.getInt("mst_k");
  opt.run.threads = non_negative(par, "threads");
  opt.mfps.seed = uint64_t(non_negative(par, "seed"));
  if (opt.method == nhnet::Method::NhNet)
    opt.model.path = par.getString("model").trimmed().toStdString();
  opt.run.progress = progress_of(cb);
  oopt.run = opt.run;

  Vertices v = copy_in(mm.cm);
  nhnet::EstimateResult res = nhnet::estimate_normals(v.points, opt);
  nhnet::OrientResult ores;
  if (oopt.mode != nhnet::OrientMode::None)
    ores = nhnet::orient_normals(v.points, res.normals, oopt, v.normals);

  // Copy out: failed points get a zero normal (MeshLab's "no normal").
  for (size_t i = 0; i < v.ptr.size(); ++i)
    v.ptr[i]->N() = res.valid[i] ? point3m(res.normals, Eigen::Index(i)) : Point3m(0, 0, 0);
  mm.updateDataMask(MeshModel::MM_VERTNORMAL);

  for (const std::string& w : res.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
  Log("NH-Net: normals of %d vertices (%lld failed), method %s, k %d, scales %s, noise ratio "
      "%.3g, %lld feature candidates; orientation %s: %lld flipped, %lld undecided",
      int(v.ptr.size()), (long long)res.failed, nhnet::to_string(opt.method), res.k_used,
      qUtf8Printable(join(res.scales_used)), res.noise_ratio, (long long)res.candidates,
      nhnet::to_string(oopt.mode), (long long)ores.flipped, (long long)ores.unoriented);
}

void NhnetFilterPlugin::denoise(MeshModel& mm, const RichParameterList& par, vcg::CallBackPos* cb) {
  nhnet::DenoiseOptions opt;
  opt.iterations = par.getInt("iterations");
  opt.radius = double(par.getFloat("radius"));
  const GuideNormals guide = choice(kGuides, par, "normals");
  opt.run.threads = non_negative(par, "threads");
  opt.run.progress = progress_of(cb);

  Vertices v = copy_in(mm.cm);
  if (guide == GuideNormals::Current) {
    if (v.normals.rows() > 0 && v.normals.cwiseAbs().maxCoeff() == 0)
      throw nhnet::UnprocessableInput(
          "the vertices have no normals; choose 'estimate first' for Normals, or run "
          "'Estimate normals (NH-Net)' before");
  } else {
    nhnet::EstimateOptions eopt;
    eopt.run = opt.run;
    nhnet::EstimateResult est = nhnet::estimate_normals(v.points, eopt);
    nhnet::orient_like(est.normals, v.normals);
    for (const std::string& w : est.warnings) Log(GLLogStream::WARNING, "NH-Net: " + w);
    v.normals = est.normals;  // NaN rows (failed points) are skipped by the denoiser
  }
  nhnet::DenoiseResult res = nhnet::denoise_points(v.points, v.normals, opt);

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
