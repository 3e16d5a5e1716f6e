// nhnet::pcl::NHNetNormalEstimation: the nhnet estimator behind the interface of
// pcl::NormalEstimationOMP, so PCL code switches by changing one type name. This is the only
// nhnet header that includes PCL; it is a thin adapter over nhnet::estimate_normals (copy the
// points in, call the core, copy normals and curvature out, flip towards the viewpoint; with
// setComputeConfidence(true) also each normal's confidence, getConfidence()).
//
//   pcl::PointCloud<pcl::PointXYZ>::Ptr cloud = ...;
//   nhnet::pcl::NHNetNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
//   ne.setInputCloud(cloud);
//   ne.setNumberOfThreads(4);      // 0 = all cores (as in PCL)
//   ne.setKSearch(30);             // optional: 0 (default) = chosen from the noise level
//   pcl::PointCloud<pcl::Normal> normals;
//   ne.compute(normals);           // normals[i] belongs to (*cloud)[i] (or to indices[i])
//
// Behaviour as pcl::NormalEstimationOMP: output has one point per index (all points without
// setIndices), header copied, width x height as the input when computed for every point;
// a point that is not finite or whose neighbourhood is degenerate gets NaN normal_x/y/z and
// curvature and output.is_dense = false; every normal is flipped towards the viewpoint
// (setViewPoint, default the origin, as PCL). Differences, by design:
//   - neighbourhoods always come from the whole input cloud (like PCL without setSearchSurface)
//     and nhnet's own kd-tree: setSearchMethod() is accepted and ignored;
//   - no radius search: nhnet uses k nearest neighbours (setKSearch) and, for MFPS, its own
//     multi-scale patch sizes (setScales);
//   - the default method is MFPS (sharp features preserved); setMethod(nhnet::Method::Pca) gives
//     PCA normals, which agree with PCL's to rounding for the same k;
//   - curvature is PCA's surface variation lambda_0 / (lambda_0 + lambda_1 + lambda_2) over the
//     k_used neighbours, PCL's definition, also when the normal comes from MFPS.
// Invalid options (k = 1 or 2, scales < 4) throw nhnet::InvalidOptions; a cloud with fewer than 3
// finite points gives all-NaN normals (as PCL would), not an exception.
#pragma once

#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <pcl/pcl_base.h>
#include <pcl/point_cloud.h>
#include <pcl/search/search.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace nhnet {
namespace pcl {

template <typename PointInT, typename PointOutT>
class NHNetNormalEstimation : public ::pcl::PCLBase<PointInT> {
 public:
  using Ptr = std::shared_ptr<NHNetNormalEstimation<PointInT, PointOutT>>;
  using ConstPtr = std::shared_ptr<const NHNetNormalEstimation<PointInT, PointOutT>>;
  using PointCloudIn = ::pcl::PointCloud<PointInT>;
  using PointCloudOut = ::pcl::PointCloud<PointOutT>;
  using KdTree = ::pcl::search::Search<PointInT>;
  using KdTreePtr = typename KdTree::Ptr;
  using ::pcl::PCLBase<PointInT>::input_;
  using ::pcl::PCLBase<PointInT>::indices_;

  /// \param nr_threads worker threads, 0 = all cores (PCL's NormalEstimationOMP constructor).
  explicit NHNetNormalEstimation(unsigned int nr_threads = 0) { setNumberOfThreads(nr_threads); }

  /// Worker threads, 0 = all cores.
  void setNumberOfThreads(unsigned int nr_threads = 0) { options_.run.threads = int(nr_threads); }
  /// Neighbourhood size of PCA (self included, >= 3); 0 = chosen from the cloud's noise level.
  void setKSearch(int k) { options_.k = k; }
  int getKSearch() const { return options_.k; }
  /// MFPS patch sizes (each >= 4), e.g. {50, 100, 150}; empty = chosen from the noise level.
  void setScales(const std::vector<int>& scales) { options_.mfps.scales = scales; }
  const std::vector<int>& getScales() const { return options_.mfps.scales; }
  /// nhnet::Method::Mfps (default) or nhnet::Method::Pca.
  void setMethod(Method method) { options_.method = method; }
  Method getMethod() const { return options_.method; }
  /// Seed of MFPS's random plane samples (deterministic results for a seed).
  void setSeed(uint64_t seed) { options_.mfps.seed = seed; }
  /// Every other option of the core (MFPS plane search, progress/cancel callback, ...).
  void setEstimateOptions(const EstimateOptions& options) { options_ = options; }
  const EstimateOptions& getEstimateOptions() const { return options_; }

  /// Accepted for drop-in compatibility with pcl::NormalEstimation and ignored: nhnet builds its
  /// own kd-tree over the input cloud (one tree for every neighbourhood size it needs).
  void setSearchMethod(const KdTreePtr& tree) { tree_ = tree; }
  KdTreePtr getSearchMethod() const { return tree_; }

  /// Normals are flipped so that dot(normal, viewpoint - point) >= 0 (PCL's convention).
  void setViewPoint(float vpx, float vpy, float vpz) {
    vpx_ = vpx;
    vpy_ = vpy;
    vpz_ = vpz;
    use_sensor_origin_ = false;
  }
  void getViewPoint(float& vpx, float& vpy, float& vpz) const {
    vpx = vpx_;
    vpy = vpy_;
    vpz = vpz_;
  }
  /// Use the input cloud's sensor_origin_ as the viewpoint (PCL's default behaviour too).
  void useSensorOriginAsViewPoint() { use_sensor_origin_ = true; }

  /// Also compute each normal's confidence (getConfidence(); default off, the core's
  /// EstimateOptions::confidence).
  void setComputeConfidence(bool on) { options_.confidence = on; }
  bool getComputeConfidence() const { return options_.confidence; }
  /// After compute() with setComputeConfidence(true): per output point (per index), the chance in
  /// [0, 1] that its normal is within 30 degrees of the true one, judged from its neighbourhood
  /// (nhnet/learned/confidence.hpp); NaN where the normal is NaN. Empty otherwise.
  const std::vector<float>& getConfidence() const { return confidence_; }

  /// Statistics of the last compute(): failed count, noise ratio, k and scales used, warnings.
  const EstimateResult& getLastResult() const { return result_; }

  /// Estimates a normal (normal_x/y/z) and curvature for every point of the input (or of the
  /// indices). Throws nhnet::InvalidOptions for invalid options, nhnet::Cancelled when the
  /// progress callback of setEstimateOptions() asks to stop.
  void compute(PointCloudOut& output) {
    if (!this->initCompute()) {  // PCLBase prints the reason (no input cloud, bad indices)
      output.width = output.height = 0;
      output.clear();
      return;
    }
    const std::size_t count = indices_->size();
    output.header = input_->header;
    output.resize(count);
    if (count != input_->size() || input_->width * input_->height == 0) {
      output.width = static_cast<std::uint32_t>(count);
      output.height = 1;
    } else {
      output.width = input_->width;
      output.height = input_->height;
    }
    output.is_dense = true;

    if (use_sensor_origin_) {
      vpx_ = input_->sensor_origin_.coeff(0);
      vpy_ = input_->sensor_origin_.coeff(1);
      vpz_ = input_->sensor_origin_.coeff(2);
    }
    Points points(Eigen::Index(input_->size()), 3);
    for (std::size_t i = 0; i < input_->size(); ++i) {
      const PointInT& p = (*input_)[i];
      points.row(Eigen::Index(i)) << double(p.x), double(p.y), double(p.z);
    }
    try {
      result_ = estimate_normals(points, options_);
    } catch (const UnprocessableInput& e) {  // fewer than 3 finite points: all NaN, as PCL
      result_ = EstimateResult();
      result_.normals.setConstant(points.rows(), 3, std::numeric_limits<double>::quiet_NaN());
      result_.curvature.setConstant(points.rows(), std::numeric_limits<double>::quiet_NaN());
      result_.valid.assign(std::size_t(points.rows()), 0);
      result_.failed = points.rows();
      result_.warnings.push_back(e.what());
    }

    const float nan = std::numeric_limits<float>::quiet_NaN();
    const bool scored = result_.confidence.size() == points.rows();
    confidence_.assign(options_.confidence ? count : 0, nan);
    for (std::size_t j = 0; j < count; ++j) {
      const auto i = Eigen::Index((*indices_)[j]);
      PointOutT& out = output[j];
      if (scored && result_.valid[std::size_t(i)]) confidence_[j] = float(result_.confidence[i]);
      const PointInT& p = (*input_)[std::size_t(i)];
      if (!result_.valid[std::size_t(i)]) {
        out.normal_x = out.normal_y = out.normal_z = out.curvature = nan;
        output.is_dense = false;
        continue;
      }
      float nx = float(result_.normals(i, 0)), ny = float(result_.normals(i, 1)),
            nz = float(result_.normals(i, 2));
      if ((vpx_ - p.x) * nx + (vpy_ - p.y) * ny + (vpz_ - p.z) * nz < 0) {
        nx = -nx;
        ny = -ny;
        nz = -nz;
      }
      out.normal_x = nx;
      out.normal_y = ny;
      out.normal_z = nz;
      out.curvature = float(result_.curvature[i]);
    }
    this->deinitCompute();
  }

 private:
  EstimateOptions options_;
  EstimateResult result_;
  std::vector<float> confidence_;
  KdTreePtr tree_;
  float vpx_ = 0, vpy_ = 0, vpz_ = 0;
  bool use_sensor_origin_ = true;
};

}  // namespace pcl
}  // namespace nhnet
