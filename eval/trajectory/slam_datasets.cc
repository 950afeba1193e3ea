#include "eval/trajectory/slam_datasets.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <stdexcept>

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <zlib.h>

#include "formats/flight_log/kitti_oxts.h"
#include "formats/rectified_stereo.h"
#include "formats/stereo/image_io.h"
#include "formats/stereo/pair_prefetch.h"
#include "formats/stereo/rectifier.h"
#include "formats/stereo/stereo_source.h"
#include "formats/trajectory/trajectory_file.h"
#include "stages/slam/slam_pipeline.h"
#include "eval/trajectory/trajectory_transform.h"

namespace rs {
namespace {

using Clock = std::chrono::steady_clock;
double CpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void RotationRelFirst(const PosePairs& pairs, SlamRunReport* rep) {
  rep->rot_rel_first_err.clear();
  rep->gt_rel_first_deg.clear();
  if (pairs.size() == 0) return;
  const Eigen::Matrix3d e0 = pairs.est[0].linear().transpose(), g0 = pairs.gt[0].linear().transpose();
  double sum = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Eigen::Matrix3d g = g0 * pairs.gt[i].linear();
    const Eigen::AngleAxisd d(g.transpose() * (e0 * pairs.est[i].linear()));
    const double a = d.angle() * 180.0 / M_PI;
    rep->rot_rel_first_err.push_back(a * d.axis());
    rep->gt_rel_first_deg.push_back(Eigen::AngleAxisd(g).angle() * 180.0 / M_PI);
    sum += a * a;
  }
  rep->rot_rel_first_rmse_deg = std::sqrt(sum / pairs.size());
}

double PathLength(const PosePairs& pairs) {
  double len = 0;
  for (size_t i = 1; i < pairs.size(); ++i) len += (pairs.gt[i].translation() - pairs.gt[i - 1].translation()).norm();
  return len;
}

void MeasureResiduals(const StereoCalibration& calib, SlamRunReport* rep) {
  const MapResiduals r = LevelZeroResiduals(rep->result.map, RectifiedStereoOf(calib));
  rep->reproj_median_px = r.median_px;
  rep->reproj_p90_px = r.p90_px;
  rep->reproj_right_median_px = r.right_median_px;
}

// Runs SLAM over `source` frames; `rectify` (may be null) maps raw pairs to rectified ones.
SlamRunReport RunSource(const StereoSource& source, const StereoCalibration& rectified, const SlamOptions& options,
                        const StereoRectifier* rectifier, int max_frames,
                        const std::vector<std::optional<PosePrior>>* priors) {
  SlamRunReport rep;
  rep.width = rectified.left.width;
  rep.height = rectified.left.height;
  StereoSlam slam(rectified, options);
  // As in the slam stage: pairs decoded ahead on worker threads, later frames' features extracted
  // while a frame is tracked (options.parallel; same results). The wall time includes the decoding.
  const size_t n = max_frames < 0 ? source.frames().size() : std::min<size_t>(max_frames, source.frames().size());
  std::vector<StereoPairFiles> files;
  for (size_t i = 0; i < n; ++i) files.push_back({source.frames()[i].left, source.frames()[i].right});
  SlamPipeline pipeline(&slam, options.parallel);
  const double c0 = CpuSeconds();
  const auto t0 = Clock::now();
  StereoPairPrefetcher images(std::move(files), kSlamDecodeAheadPairs);
  for (size_t i = 0; i < n; ++i) {
    const auto tl = Clock::now();
    auto [l, r] = images.Next();
    if (rectifier) {
      cv::Mat lr, rr;
      rectifier->Rectify(l, r, &lr, &rr);
      l = lr;
      r = rr;
    }
    rep.load_s += std::chrono::duration<double>(Clock::now() - tl).count();
    if (auto f = pipeline.Push(source.frames()[i].t_ns, l, r, priors ? (*priors)[i] : std::nullopt))
      rep.frames.push_back(*f);
  }
  for (FrameResult& f : pipeline.Flush()) rep.frames.push_back(f);
  const double c1 = CpuSeconds();
  rep.result = slam.Finish();
  rep.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  rep.cpu_s = CpuSeconds() - c0;
  if (options.parallel) {
    rep.finish_cpu_s = CpuSeconds() - c1;
    rep.two_core_wall_s = pipeline.times().TwoCoreWallSeconds() + rep.finish_cpu_s;
    rep.features_cpu_s = pipeline.times().extract_cpu_s;
    rep.track_cpu_s = pipeline.times().track_cpu_s;
  }
  MeasureResiduals(rectified, &rep);
  return rep;
}

// The float32 2-D array of a NumPy .npz holding one deflated (or stored) .npy member.
cv::Mat ReadNpzFloatImage(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string zip((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto u16 = [&](size_t o) {
    return static_cast<uint32_t>(static_cast<uint8_t>(zip[o]) | static_cast<uint8_t>(zip[o + 1]) << 8);
  };
  auto u32 = [&](size_t o) { return u16(o) | u16(o + 2) << 16; };
  const std::string where = path.string();
  if (zip.size() < 30 || u32(0) != 0x04034b50) throw std::runtime_error(where + ": not a zip (.npz) file");
  const uint32_t method = u16(8), packed = u32(18), size = u32(22), name_len = u16(26), extra_len = u16(28);
  const size_t data = 30 + name_len + extra_len;
  if ((u16(6) & 8) || packed == 0 || size == 0 || data + packed > zip.size())
    throw std::runtime_error(where + ": unsupported zip member (sizes in a data descriptor or truncated)");
  std::string npy(size, '\0');
  if (method == 0) {
    npy.assign(zip, data, size);
  } else if (method == 8) {
    z_stream zs{};
    if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) throw std::runtime_error(where + ": zlib init failed");
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(zip.data() + data));
    zs.avail_in = packed;
    zs.next_out = reinterpret_cast<Bytef*>(npy.data());
    zs.avail_out = size;
    const int rc = inflate(&zs, Z_FINISH);
    inflateEnd(&zs);
    if (rc != Z_STREAM_END) throw std::runtime_error(where + ": corrupt deflate data");
  } else {
    throw std::runtime_error(where + ": zip compression method " + std::to_string(method) + " unsupported");
  }
  // .npy v1/v2: magic, version, header length, then a Python dict literal.
  if (npy.size() < 12 || npy.compare(0, 6, "\x93NUMPY") != 0) throw std::runtime_error(where + ": member is not .npy");
  const bool v1 = npy[6] == 1;
  const size_t hlen =
      v1 ? (static_cast<uint8_t>(npy[8]) | static_cast<uint8_t>(npy[9]) << 8)
         : (static_cast<uint8_t>(npy[8]) | static_cast<uint8_t>(npy[9]) << 8 | static_cast<uint8_t>(npy[10]) << 16);
  const size_t start = (v1 ? 10 : 12) + hlen;
  const std::string header = npy.substr(v1 ? 10 : 12, hlen);
  int rows = 0, cols = 0;
  const size_t sp = header.find("'shape': (");
  if (header.find("'<f4'") == std::string::npos || header.find("'fortran_order': False") == std::string::npos ||
      sp == std::string::npos || std::sscanf(header.c_str() + sp + 10, "%d, %d", &rows, &cols) != 2 ||
      start + static_cast<size_t>(rows) * cols * 4 > npy.size())
    throw std::runtime_error(where + ": expected a C-order float32 2-D array, header " + header);
  cv::Mat m(rows, cols, CV_32F);
  std::memcpy(m.data, npy.data() + start, static_cast<size_t>(rows) * cols * 4);
  return m;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

MapResiduals LevelZeroResiduals(const SlamMap& m, const RectifiedStereo& cam) {
  std::vector<double> uv, ur;
  for (const MapPoint& p : m.points) {
    if (p.bad) continue;
    for (const auto& [k, f] : p.observations) {
      const Keyframe& kf = m.keyframes[k];
      const cv::KeyPoint& kp = kf.features.keypoints[f];
      if (kf.bad || kp.octave != 0) continue;
      const Eigen::Vector3d pc = kf.T_cam_world * p.p_world;
      if (pc.z() <= 0) continue;
      const double u = cam.f_px * pc.x() / pc.z() + cam.cx_px, v = cam.f_px * pc.y() / pc.z() + cam.cy_px;
      uv.push_back(std::hypot(kp.pt.x - u, kp.pt.y - v));
      if (kf.features.u_right[f] >= 0)
        ur.push_back(std::abs(kf.features.u_right[f] - (u - cam.f_px * cam.baseline_m / pc.z())));
    }
  }
  auto quantile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
    std::nth_element(v.begin(), v.begin() + i, v.end());
    return v[i];
  };
  return {quantile(uv, 0.5), quantile(uv, 0.9), quantile(ur, 0.5)};
}

LidarDisparityCheck CheckDisparityAgainstLidar(const std::filesystem::path& drive, const SlamOptions& options) {
  const StereoSource source = OpenStereoSource(drive, "kitti-raw");
  if (!source.calibration()) throw std::runtime_error(drive.string() + ": no calibration");
  const StereoCalibration& c = *source.calibration();
  const RectifiedStereo cam = RectifiedStereoOf(c);
  const ScalePyramid pyr(options.pyramid_levels, options.scale_factor);
  std::vector<double> deficit, ratio;
  for (const StereoFrame& fr : source.frames()) {
    const std::filesystem::path npz =
        drive / "proj_depth" / "velodyne" / "image_02" / (fr.left.stem().string() + ".npz");
    if (!std::filesystem::exists(npz)) continue;
    const cv::Mat lidar = ReadNpzFloatImage(npz);
    const StereoFeatures f = ExtractStereoFeatures(LoadGray8(fr.left), LoadGray8(fr.right), cam, options, pyr);
    if (lidar.rows != cam.height || lidar.cols != cam.width)
      throw std::runtime_error(npz.string() + ": size differs from the images");
    for (size_t i = 0; i < f.size(); ++i) {
      if (f.depth_m[i] <= 0) continue;
      const int x = static_cast<int>(std::lround(f.keypoints[i].pt.x)),
                y = static_cast<int>(std::lround(f.keypoints[i].pt.y));
      // LiDAR samples around the corner; a spread above 5 % means a depth edge (LiDAR sees past it).
      std::vector<double> z;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= lidar.cols || yy >= lidar.rows) continue;
          const float v = lidar.at<float>(yy, xx);
          if (v > 0) z.push_back(v);
        }
      if (z.size() < 2) continue;
      std::sort(z.begin(), z.end());
      if (z.back() > 1.05 * z.front()) continue;
      const double zl = z[z.size() / 2];
      deficit.push_back(cam.bf() / zl - cam.bf() / f.depth_m[i]);
      ratio.push_back(f.depth_m[i] / zl);
    }
  }
  LidarDisparityCheck out;
  out.samples = static_cast<int>(deficit.size());
  out.median_deficit_px = Median(deficit);
  out.median_depth_ratio = ratio.empty() ? 1.0 : Median(ratio);
  return out;
}

std::string SlamRunReport::Summary(const std::string& name) const {
  const int frames = result.stats.frames;
  return fmt::format(
      "{}: {}x{}, {}\n  ATE RMSE (SE3) {:.4f} m ({:.3f} % of {:.1f} m path), max {:.4f} m, rot RMSE {:.3f} deg "
      "(aligned; relative to the first frame, unaligned: {:.3f} deg)\n"
      "  wall {:.2f} s = {:.1f} frames/s (local mapping {:.2f} s, finish {:.2f} s), CPU {:.2f} s = {:.1f} "
      "frames/CPU-s, "
      "two free cores (from thread CPU) {:.2f} s = {:.1f} frames/s, waiting for images {:.2f} s\n"
      "  CPU per frame: features {:.1f} ms, tracking + local mapping {:.1f} ms, finish {:.1f} ms\n  level-0 "
      "reprojection residual median {:.3f} px (p90 {:.3f}), right-u median {:.3f} px",
      name, width, height, result.stats.BriefReport(), ate.translation_m.rmse,
      path_length_m > 0 ? 100 * ate.translation_m.rmse / path_length_m : 0.0, path_length_m, ate.translation_m.max,
      ate.rotation_deg.rmse, rot_rel_first_rmse_deg, wall_s, frames / std::max(1e-9, wall_s),
      result.stats.local_mapping_s, result.stats.finish_s, cpu_s, frames / std::max(1e-9, cpu_s), two_core_wall_s,
      two_core_wall_s > 0 ? frames / two_core_wall_s : 0.0, load_s, 1e3 * features_cpu_s / std::max(1, frames),
      1e3 * track_cpu_s / std::max(1, frames), 1e3 * finish_cpu_s / std::max(1, frames), reproj_median_px,
      reproj_p90_px, reproj_right_median_px);
}

SlamRunReport RunKittiOdometry(const std::filesystem::path& folder, const SlamOptions& options, int max_frames) {
  const StereoSource source = OpenStereoSource(folder, "kitti-odometry");
  SlamRunReport rep = RunSource(source, *source.calibration(), options, nullptr, max_frames, nullptr);
  Trajectory gt = ReadTrajectory(folder / "poses.txt", TrajectoryFormat::kKitti);
  gt.poses.resize(rep.result.frames.poses.size());
  Trajectory est = rep.result.frames;
  const PosePairs pairs = AssociateByIndex(est, gt);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  RotationRelFirst(pairs, &rep);
  return rep;
}

SlamRunReport RunKittiRaw(const std::filesystem::path& drive, const SlamOptions& options) {
  const StereoSource source = OpenStereoSource(drive, "kitti-raw");
  if (!source.calibration()) throw std::runtime_error(drive.string() + ": no calibration");
  SlamRunReport rep = RunSource(source, *source.calibration(), options, nullptr, -1, nullptr);
  const FlightTrack oxts = ReadKittiOxts(drive / "oxts");
  if (oxts.fixes.size() != source.frames().size())
    throw std::runtime_error(
        fmt::format("{}: {} OXTS records for {} frames", drive.string(), oxts.fixes.size(), source.frames().size()));
  const GnssFix& o = oxts.fixes.front();
  const GeographicLib::LocalCartesian enu(o.lat_deg, o.lon_deg, o.alt_m);
  Trajectory gt;
  for (size_t i = 0; i < oxts.fixes.size(); ++i) {
    const GnssFix& f = oxts.fixes[i];
    StampedPose p;
    p.t_ns = source.frames()[i].t_ns;
    enu.Forward(f.lat_deg, f.lon_deg, f.alt_m, p.T_world_frame.translation().x(), p.T_world_frame.translation().y(),
                p.T_world_frame.translation().z());
    gt.poses.push_back(p);
  }
  const PosePairs pairs = AssociateByIndex(rep.result.frames, gt);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  return rep;
}

SlamRunReport RunEuroc(const std::filesystem::path& dataset, const std::filesystem::path& gt_tum,
                       const SlamOptions& options) {
  const StereoSource source = OpenStereoSource(dataset, "euroc");
  const StereoRectifier rectifier = StereoRectifier::Create(*source.calibration());
  SlamRunReport rep = RunSource(source, rectifier.rectified(), options, &rectifier, -1, nullptr);
  // T_body_cam0 from cam0/sensor.yaml, then the rectifying rotation: T_body_rect = T_BS * [R1^T | 0].
  cv::FileStorage fs((dataset / "mav0" / "cam0" / "sensor.yaml").string(), cv::FileStorage::READ);
  std::vector<double> data;
  fs["T_BS"]["data"] >> data;
  if (data.size() != 16) throw std::runtime_error("cam0/sensor.yaml: T_BS.data needs 16 numbers");
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_body_cam.linear()(r, c) = data[r * 4 + c];
    T_body_cam.translation()(r) = data[r * 4 + 3];
  }
  Eigen::Isometry3d T_cam_rect = Eigen::Isometry3d::Identity();
  const auto& R1 = rectifier.R_rectleft_left();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) T_cam_rect.linear()(r, c) = R1[c * 3 + r];
  const Trajectory gt = ApplyExtrinsic(ReadTrajectory(gt_tum, TrajectoryFormat::kTum), T_body_cam * T_cam_rect);
  const PosePairs pairs = AssociateByTimestamp(rep.result.frames, gt, 2'000'000);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  RotationRelFirst(pairs, &rep);
  return rep;
}

SlamRunReport RunSimulated(const std::filesystem::path& folder, const SlamOptions& options, bool use_priors,
                           double prior_noise_m) {
  const StereoSource source = OpenStereoSource(folder, "plain");
  const Trajectory gt = ReadTrajectory(folder / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  std::vector<std::optional<PosePrior>> priors(source.frames().size());
  if (use_priors) {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0, prior_noise_m);
    for (size_t i = 0; i < priors.size() && i < gt.poses.size(); ++i) {
      PosePrior p;
      p.T_world_cam = gt.poses[i].T_world_frame;
      p.T_world_cam.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      p.has_attitude = false;
      p.sigma_position_m = prior_noise_m;
      priors[i] = p;
    }
  }
  SlamRunReport rep = RunSource(source, *source.calibration(), options, nullptr, -1, &priors);
  const PosePairs pairs = AssociateByTimestamp(rep.result.frames, gt, 1'000'000);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  RotationRelFirst(pairs, &rep);
  return rep;
}

}  // namespace rs
