// PCL peer of the benchmark: NormalEstimationOMP (PCA over the k nearest neighbours).
#include "peers.hpp"

#include <pcl/features/normal_3d_omp.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <limits>

namespace nhnet_bench {

nhnet::Normals pcl_pca_normals(const nhnet::Points& points, int k, int threads) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(size_t(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    (*cloud)[size_t(i)] =
        pcl::PointXYZ(float(points(i, 0)), float(points(i, 1)), float(points(i, 2)));

  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(threads);
  ne.setInputCloud(cloud);
  ne.setSearchMethod(
      pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
  ne.setKSearch(k);
  pcl::PointCloud<pcl::Normal> out;
  ne.compute(out);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  nhnet::Normals n(points.rows(), 3);
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const pcl::Normal& q = out[size_t(i)];
    if (std::isfinite(q.normal_x) && std::isfinite(q.normal_y) && std::isfinite(q.normal_z))
      n.row(i) << q.normal_x, q.normal_y, q.normal_z;
    else
      n.row(i) << nan, nan, nan;
  }
  return n;
}

}  // namespace nhnet_bench
