// Peer normal estimators run by the benchmark (bench/nhnet_bench.py through nhnet-bench-worker):
// PCL NormalEstimationOMP and CGAL jet / VCM. Only std, Eigen and nhnet types here; PCL and CGAL
// are included by peer_pcl.cpp and peer_cgal.cpp alone, so neither reaches the core.
#pragma once

#include "nhnet/types.hpp"

namespace nhnet_bench {

/// PCL `NormalEstimationOMP<PointXYZ, Normal>` over the k nearest neighbours (pcl::search::KdTree),
/// `threads` OpenMP threads. Failed points (PCL returns NaN) stay NaN.
nhnet::Normals pcl_pca_normals(const nhnet::Points& points, int k, int threads);

/// CGAL `jet_estimate_normals` (degree-2 jet over the k nearest neighbours), parallel with TBB
/// on `threads` threads when CGAL was built with TBB.
nhnet::Normals cgal_jet_normals(const nhnet::Points& points, int k, int threads);

/// CGAL `vcm_estimate_normals` (Voronoi covariance measure, sequential in CGAL 5.5): offset radius
/// = `offset_spacings` x the average spacing (CGAL compute_average_spacing over 6 neighbours,
/// included in the timed call), convolution over a ball holding about k points (radius = median
/// k-NN distance over a sample; also timed).
nhnet::Normals cgal_vcm_normals(const nhnet::Points& points, int k, double offset_spacings,
                                int threads);

}  // namespace nhnet_bench
