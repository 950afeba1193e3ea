#include "eval/damage/pothole_scan_eval.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <pcl/console/print.h>
#include <pcl/io/ply_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include "formats/input_error.h"
#include "formats/rectified_stereo.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "stages/disparity/disparity.h"

namespace rs {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// The road plane n . X = h in the left camera frame (metres, n unit, towards the road): a planar
// disparity d = (B/h) n . (u - cx, v - cy, f), so (c_u, c_v, d(cx, cy) / f) = (B/h) n.
struct Plane {
  Eigen::Vector3d n;
  double h = 0;
};

Plane PlaneOfRoadModel(const RoadModel& m, const RectifiedStereo& g) {
  const Eigen::Vector3d k(m.c[1], m.c[2], m.At(g.cx_px, g.cy_px) / g.f_px);
  return {k.normalized(), g.baseline_m / k.norm()};
}

// Least-squares plane through points (SVD of the centred set), normal oriented like `like`.
Plane FitPlane(const std::vector<Eigen::Vector3d>& p, const Eigen::Vector3d& like) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : p) mean += x;
  mean /= static_cast<double>(p.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& x : p) cov += (x - mean) * (x - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Eigen::Vector3d n = es.eigenvectors().col(0);
  if (n.dot(like) < 0) n = -n;
  return {n, n.dot(mean)};
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = static_cast<size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// delta: the largest disparity drop of a point max_depth below the road plane in this view. A plane
// parallel to the road and D farther has disparity d h / (h + D), so the drop is d D / (h + D),
// largest where the road's disparity is (a corner of the image, the model being planar).
double DeltaForDepth(const RoadModel& m, const Plane& road, int W, int H, double max_depth_m) {
  double d_max = 0;
  for (const double u : {0.0, W - 1.0})
    for (const double v : {0.0, H - 1.0}) d_max = std::max(d_max, m.At(u, v));
  return std::ceil(d_max * max_depth_m / (road.h + max_depth_m));
}

// The pothole: valid pixels deeper than `cut` below the road, the 8-connected component with the
// largest summed depth (a pothole, not the scatter of the asphalt's texture), its holes filled.
cv::Mat PotholeRegion(const cv::Mat& depth_m, const cv::Mat& valid, double cut_m) {
  cv::Mat deep = (depth_m > cut_m) & valid;
  cv::Mat labels;
  const int n = cv::connectedComponents(deep, labels, 8, CV_32S);
  std::vector<double> volume(static_cast<size_t>(n), 0.0);
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u)
      if (const int l = labels.at<int>(v, u); l > 0) volume[l] += depth_m.at<double>(v, u);
  const auto best = std::max_element(volume.begin() + 1, volume.end());
  if (n < 2 || *best <= 0) throw std::runtime_error("no region below the road plane");
  cv::Mat region = labels == static_cast<int>(best - volume.begin());
  // Fill the holes: everything the outside cannot reach from the image border.
  cv::Mat outside = region.clone();
  cv::copyMakeBorder(outside, outside, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::floodFill(outside, cv::Point(0, 0), 255);
  cv::Mat inner = outside(cv::Rect(1, 1, region.cols, region.rows));
  return region | (inner == 0);
}

Cloud::Ptr EvenSubsample(const Cloud& c, int max_points) {
  auto out = std::make_shared<Cloud>();
  const size_t step = std::max<size_t>(1, (c.size() + max_points - 1) / std::max(1, max_points));
  for (size_t i = 0; i < c.size(); i += step) out->push_back(c[i]);
  return out;
}

// RMS and median of each source point's distance to its nearest target point.
std::pair<double, double> ClosestPointStats(const Cloud& source, const pcl::KdTreeFLANN<pcl::PointXYZ>& tree) {
  std::vector<int> idx(1);
  std::vector<float> d2(1);
  std::vector<double> d;
  double sum = 0;
  for (const auto& p : source) {
    tree.nearestKSearch(p, 1, idx, d2);
    sum += d2[0], d.push_back(std::sqrt(d2[0]));
  }
  return {std::sqrt(sum / std::max<size_t>(1, source.size())), Quantile(d, 0.5)};
}

Eigen::Vector3d DepthWeightedCentroid(const Cloud& c) {
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  double w = 0;
  for (const auto& p : c)
    if (p.z > 0) s += p.z * Eigen::Vector3d(p.x, p.y, p.z), w += p.z;
  return w > 0 ? Eigen::Vector3d(s / w) : Eigen::Vector3d::Zero();
}

}  // namespace

PotholeScanResult EvaluatePotholeScan(const std::filesystem::path& left_path, const std::filesystem::path& right_path,
                                      const std::filesystem::path& calibration_yaml,
                                      const std::filesystem::path& scan_ply, const PotholeScanOptions& o) {
  PotholeScanResult res;
  const cv::Mat left = LoadGray8(left_path), right = LoadGray8(right_path);
  if (left.size() != right.size())
    throw InputError(InputLocation::File(right_path.string()), "size differs from the left image's");
  const RectifiedStereo g = RectifiedStereoOf(ReadCalibrationYaml(calibration_yaml));
  DisparityParams params;
  params.camera_focal_px = g.f_px;
  // delta from the deepest damage to hold: the sparse road model first (as ComputeDisparity fits it).
  const RoadModel sparse = FitRoadModel(MatchSparseDisparities(left, right, params.road), left.cols, left.rows,
                                        params.road);
  if (!sparse.reliable) throw std::runtime_error(fmt::format("{}: no reliable road model", left_path.string()));
  const double delta = DeltaForDepth(sparse, PlaneOfRoadModel(sparse, g), left.cols, left.rows, o.max_depth_m);
  params.gpt_delta_px = std::max(params.gpt_delta_px, delta);
  // The default range keeps gpt_num_disparities - gpt_delta_px px above the road; so does this one.
  params.gpt_num_disparities = static_cast<int>(params.gpt_delta_px) + DisparityParams{}.gpt_num_disparities -
                               static_cast<int>(DisparityParams{}.gpt_delta_px);
  const DisparityResult r = ComputeDisparity(left, right, params);
  res.road = r.road, res.fell_back = r.fell_back, res.delta_px = params.gpt_delta_px;
  res.num_disparities = r.num_disparities;
  if (r.fell_back) throw std::runtime_error(fmt::format("{}: GPT-SGM fell back", left_path.string()));
  const cv::Mat& disp = o.sharp && !r.disparity_sharp.empty() ? r.disparity_sharp : r.disparity;

  // Camera-frame points, then the road plane refitted to the dense points near the sparse one.
  const int W = left.cols, H = left.rows;
  cv::Mat xyz(H, W, CV_64FC3, cv::Scalar::all(0));
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u)
      if (r.valid.at<uint8_t>(v, u) && disp.at<float>(v, u) > 0) {
        const double z = g.bf() / disp.at<float>(v, u);
        xyz.at<cv::Vec3d>(v, u) = {(u - g.cx_px) * z / g.f_px, (v - g.cy_px) * z / g.f_px, z};
      }
  Plane road = PlaneOfRoadModel(r.road, g);
  for (const double band_m : {0.005, 0.003}) {  // two refits, the second inside a narrower band
    std::vector<Eigen::Vector3d> near;
    for (int v = 0; v < H; v += 2)
      for (int u = 0; u < W; u += 2) {
        const cv::Vec3d& x = xyz.at<cv::Vec3d>(v, u);
        if (x[2] > 0 && std::abs(road.n.dot(Eigen::Vector3d(x[0], x[1], x[2])) - road.h) < band_m)
          near.emplace_back(x[0], x[1], x[2]);
      }
    if (near.size() < 100) throw std::runtime_error("too few road points near the road model");
    road = FitPlane(near, road.n);
  }
  res.camera_height_m = road.h;
  cv::Mat depth(H, W, CV_64F, cv::Scalar(0)), valid = cv::Mat::zeros(H, W, CV_8U);
  std::vector<double> road_depths;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const cv::Vec3d& x = xyz.at<cv::Vec3d>(v, u);
      if (!(x[2] > 0)) continue;
      const double D = road.n.dot(Eigen::Vector3d(x[0], x[1], x[2])) - road.h;
      depth.at<double>(v, u) = D, valid.at<uint8_t>(v, u) = 255;
      if (std::abs(D) < 0.003 && (u + v) % 4 == 0) road_depths.push_back(D);
    }
  const double med = Quantile(road_depths, 0.5);
  for (double& x : road_depths) x = std::abs(x - med);
  const double sigma = 1.4826 * Quantile(road_depths, 0.5);
  res.road_sigma_mm = 1000 * sigma, res.cut_mm = 1000 * o.cut_sigma * sigma;
  const cv::Mat region = PotholeRegion(depth, valid, o.cut_sigma * sigma);
  res.region_px = cv::countNonZero(region);

  // Road frame, mm: e3 = the road normal (depth below the road, as the mould's height), e1 = the
  // camera's x axis in the road plane, e2 = e3 x e1 (right-handed, as the scanner's frame).
  const Eigen::Vector3d e3 = road.n;
  const Eigen::Vector3d e1 = (Eigen::Vector3d::UnitX() - e3 * e3.x()).normalized(), e2 = e3.cross(e1);
  Cloud ours;
  std::vector<double> depths;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      if (!region.at<uint8_t>(v, u) || !valid.at<uint8_t>(v, u)) continue;
      const cv::Vec3d& x = xyz.at<cv::Vec3d>(v, u);
      const Eigen::Vector3d p(x[0], x[1], x[2]);
      const double D = depth.at<double>(v, u);
      ours.push_back(pcl::PointXYZ(float(1000 * e1.dot(p)), float(1000 * e2.dot(p)), float(1000 * D)));
      depths.push_back(1000 * D);
    }
  res.points = static_cast<int>(ours.size());
  res.max_depth_mm = Quantile(depths, 0.999);
  if (ours.size() < 100) throw std::runtime_error("pothole region has too few points");

  auto scan = std::make_shared<Cloud>();
  // The scans declare an empty face element PCL's reader reports as unhandled: errors only.
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  if (pcl::io::loadPLYFile(scan_ply.string(), *scan) != 0 || scan->empty())
    throw InputError(InputLocation::File(scan_ply.string()), "cannot read the scan as a PLY point cloud");
  res.scan_points = static_cast<int>(scan->size());
  float zmin = std::numeric_limits<float>::max(), zmax = -zmin;
  for (const auto& p : *scan) zmin = std::min(zmin, p.z), zmax = std::max(zmax, p.z);
  res.scan_depth_mm = zmax - zmin;

  // Coarse alignment: the depth-weighted centroids coincide in the road plane (the mould's base and
  // the road plane are both z = 0); the yaw about the normal is unknown (the scanner's turntable
  // frame), so ICP starts from yaw_starts yaws on a subsample and the lowest RMS wins.
  const Eigen::Vector3d c_ours = DepthWeightedCentroid(ours), c_scan = DepthWeightedCentroid(*scan);
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(scan);
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputTarget(scan);
  icp.setMaxCorrespondenceDistance(o.icp_max_correspondence_mm);
  icp.setMaximumIterations(o.icp_iterations);
  icp.setTransformationEpsilon(1e-10);
  icp.setEuclideanFitnessEpsilon(1e-10);
  auto start = [&](double yaw) {
    Eigen::Affine3f t = Eigen::Affine3f::Identity();
    t.translate(Eigen::Vector3f(float(c_scan.x()), float(c_scan.y()), 0.0f));
    t.rotate(Eigen::AngleAxisf(float(yaw), Eigen::Vector3f::UnitZ()));
    t.translate(Eigen::Vector3f(float(-c_ours.x()), float(-c_ours.y()), 0.0f));
    return t.matrix();
  };
  const Cloud::Ptr coarse = EvenSubsample(ours, o.coarse_points), fine = EvenSubsample(ours, o.max_points);
  double best_rms = std::numeric_limits<double>::max();
  Eigen::Matrix4f best = Eigen::Matrix4f::Identity();
  for (int k = 0; k < o.yaw_starts; ++k) {
    const double yaw = 2 * M_PI * k / o.yaw_starts;
    Cloud aligned;
    icp.setInputSource(coarse);
    icp.align(aligned, start(yaw));
    const double rms = ClosestPointStats(aligned, tree).first;
    if (rms < best_rms) best_rms = rms, best = icp.getFinalTransformation(), res.yaw_deg = yaw * 180 / M_PI;
  }
  Cloud aligned;
  icp.setInputSource(fine);
  icp.align(aligned, best);
  res.icp_fitness_mm2 = icp.getFitnessScore(o.icp_max_correspondence_mm * o.icp_max_correspondence_mm);
  std::tie(res.rms_mm, res.median_mm) = ClosestPointStats(aligned, tree);
  return res;
}

std::vector<PotholeScanRow> EvaluatePotholeScans(const std::filesystem::path& dir, const std::vector<int>& pairs,
                                                 const PotholeScanOptions& o) {
  std::vector<PotholeScanRow> rows;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const std::string i = std::to_string(pairs[k]);
    PotholeScanRow row;
    row.pair = pairs[k];
    row.scan = fmt::format("gt/model_{}.ply", k + 1);
    row.result = EvaluatePotholeScan(dir / "left images" / ("L" + i + ".png"), dir / "right images" / ("R" + i + ".png"),
                                     dir / "calibration_rectified.yaml", dir / row.scan, o);
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string PotholeScanTable(const std::vector<PotholeScanRow>& rows) {
  std::string s =
      "| pair | scan | camera height m | delta px | range px | road sigma mm | cut mm | region px | points | max depth mm "
      "(ours / scan) | yaw start deg | RMS mm | median mm |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    const PotholeScanResult& x = r.result;
    s += fmt::format("| L{0}/R{0} | {1} | {2:.3f} | {3:.0f} | {4} | {5:.2f} | {6:.2f} | {7} | {8} | {9:.1f} / {10:.1f} | "
                     "{11:.0f} | **{12:.2f}** | {13:.2f} |\n",
                     r.pair, r.scan, x.camera_height_m, x.delta_px, x.num_disparities, x.road_sigma_mm, x.cut_mm,
                     x.region_px, x.points, x.max_depth_mm, x.scan_depth_mm, x.yaw_deg, x.rms_mm, x.median_mm);
  }
  return s;
}

}  // namespace rs
