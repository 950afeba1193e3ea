// roadsurvey stereo LEFT RIGHT -o DISP.png: the disparity stage's matcher on one pair of plain
// image files (COLMAP-style): KITTI 16-bit disparity, optional transformed disparity, colour
// preview and metric point cloud.
#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <tbb/global_control.h>

#include "cli/command.h"
#include "cli/tool_util.h"
#include "formats/input_error.h"
#include "formats/rectified_stereo.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "formats/stereo/rectifier.h"
#include "stages/disparity/disparity.h"
#include "formats/disparity/disparity_io.h"

namespace rs {
namespace {

/// Binary little-endian PLY of every valid pixel in the left camera frame (x right, y down,
/// z forward, metres), coloured by the left grey value: Z = f B / d, X = (u - cx) Z / f,
/// Y = (v - cy) Z / f. Returns the number of points.
int64_t WriteCloudPly(const std::string& path, const cv::Mat& disparity, const cv::Mat& valid, const cv::Mat& gray,
                      const RectifiedStereo& g) {
  int64_t n = 0;
  for (int v = 0; v < disparity.rows; ++v)
    for (int u = 0; u < disparity.cols; ++u) n += valid.at<uint8_t>(v, u) && disparity.at<float>(v, u) > 0;
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\ncomment roadsurvey stereo: left camera frame "
         "(x right, y down, z forward), metres\n"
      << "element vertex " << n
      << "\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  const double fb = g.f_px * g.baseline_m;
  char record[15];
  for (int v = 0; v < disparity.rows; ++v)
    for (int u = 0; u < disparity.cols; ++u) {
      const float d = disparity.at<float>(v, u);
      if (!valid.at<uint8_t>(v, u) || !(d > 0)) continue;
      const double z = fb / d;
      const float xyz[3] = {float((u - g.cx_px) * z / g.f_px), float((v - g.cy_px) * z / g.f_px), float(z)};
      std::memcpy(record, xyz, sizeof(xyz));  // x86 and ARM Linux are little-endian, as the header says
      record[12] = record[13] = record[14] = static_cast<char>(gray.at<uint8_t>(v, u));
      out.write(record, sizeof(record));
    }
  if (!out) throw std::runtime_error(fmt::format("cannot write {}", path));
  return n;
}

/// Transformed disparity: 32-bit float TIFF (exact), or 16-bit PNG in the KITTI convention.
void WriteTransformed(const std::string& path, const cv::Mat& transformed) {
  const std::string ext = std::filesystem::path(path).extension().string();
  bool ok = false;
  if (ext == ".tif" || ext == ".tiff") {
    ok = cv::imwrite(path, transformed);
  } else {
    cv::Mat valid = transformed > 0;
    ok = cv::imwrite(path, ToKittiDisparity16(transformed, valid));
  }
  if (!ok) throw std::runtime_error(fmt::format("cannot write {}", path));
}

}  // namespace

Command StereoCommand() {
  return {
      "stereo", "Dense disparity of one rectified stereo pair (GPT-SGM or SGM) -> KITTI 16-bit PNG",
      [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
        app.option_defaults()->always_capture_default();
        struct Args {
          std::string left, right, output, method = "gpt-sgm", transformed, preview, calibration, cloud;
          int min_disparity = 0, num_disparities = 128, gpt_range = 32, paths = 4, threads = 0;
          double gpt_delta = 8;
          std::optional<double> focal, baseline, cx, cy;
        };
        auto a = std::make_shared<Args>();
        app.add_option("left", a->left, "left (reference) image, rectified unless --calibration says otherwise")
            ->required();
        app.add_option("right", a->right, "right image")->required();
        app.add_option("-o,--output", a->output, "disparity output: KITTI 16-bit PNG (d * 256, 0 = invalid)")
            ->required();
        app.add_option("--method", a->method, "matcher")->check(CLI::IsMember({"gpt-sgm", "sgm"}));
        app.add_option("--min-disparity", a->min_disparity, "plain SGM (and GPT fallback): smallest disparity, px");
        app.add_option("--num-disparities", a->num_disparities,
                       "plain SGM (and GPT fallback): disparities searched, 1..1024");
        app.add_option("--gpt-range", a->gpt_range, "GPT-SGM residual search range, px");
        app.add_option("--gpt-delta", a->gpt_delta,
                       "GPT-SGM delta: residual disparity of the road's row minimum (damage down to -delta fits), px");
        app.add_option("--paths", a->paths, "SGM aggregation paths")->check(CLI::IsMember({4, 8}));
        app.add_option("--transformed", a->transformed,
                       "transformed disparity d - road(u,v) + delta: .tif/.tiff float32, else 16-bit PNG (x256)");
        app.add_option("--preview", a->preview, "colour-mapped disparity with a scale bar (PNG/JPEG)");
        auto* calib = app.add_option("--calibration", a->calibration,
                                     "native calibration.yaml: f, B, principal point; unrectified pairs are "
                                     "rectified first");
        auto* focal = app.add_option("--focal", a->focal, "rectified focal length, px (with --baseline)")
                          ->check(CLI::PositiveNumber);
        auto* baseline =
            app.add_option("--baseline", a->baseline, "stereo baseline, m (with --focal)")->check(CLI::PositiveNumber);
        auto* cx = app.add_option("--cx", a->cx, "principal point column, px (default: image centre)");
        auto* cy = app.add_option("--cy", a->cy, "principal point row, px (default: image centre)");
        focal->needs(baseline);
        baseline->needs(focal);
        cx->needs(focal);
        cy->needs(focal);
        calib->excludes(focal)->excludes(baseline)->excludes(cx)->excludes(cy);
        app.add_option("--cloud", a->cloud,
                       "point cloud of valid pixels, binary PLY in the left camera frame, metres "
                       "(needs --calibration or --focal/--baseline)");
        app.add_option("--threads", a->threads, "worker threads (0 = all cores)")->check(CLI::NonNegativeNumber);
        return [a] {
          DisparityParams params;
          params.method = a->method == "sgm" ? DisparityMethod::kSgm : DisparityMethod::kGptSgm;
          params.min_disparity = a->min_disparity;
          params.num_disparities = a->num_disparities;
          params.gpt_num_disparities = a->gpt_range;
          params.gpt_delta_px = a->gpt_delta;
          params.num_paths = a->paths;
          CheckAsOption([&] { params.Check(); });

          cv::Mat left = LoadGray8(a->left), right = LoadGray8(a->right);
          if (left.size() != right.size())
            throw InputError(InputLocation::File(a->right),
                             fmt::format("size {}x{} differs from the left image's {}x{}", right.cols, right.rows,
                                         left.cols, left.rows));
          std::optional<RectifiedStereo> geometry;
          if (!a->calibration.empty()) {
            const StereoCalibration raw = ReadCalibrationYaml(std::filesystem::path(a->calibration));
            if (raw.left.width != left.cols || raw.left.height != left.rows)
              throw InputError(InputLocation::File(a->calibration),
                               fmt::format("calibrated for {}x{} images, the pair is {}x{}", raw.left.width,
                                           raw.left.height, left.cols, left.rows));
            const StereoRectifier rectifier = StereoRectifier::Create(raw);
            if (!rectifier.is_identity()) {
              cv::Mat l, r;
              rectifier.Rectify(left, right, &l, &r);
              left = l, right = r;
              fmt::print("rectified the pair with {} (outputs are in the rectified left view)\n", a->calibration);
            }
            const StereoCalibration& rect = rectifier.rectified();
            geometry = RectifiedStereoOf(rect);
          } else if (a->focal) {
            geometry = RectifiedStereo{.f_px = *a->focal,
                                       .cx_px = a->cx.value_or((left.cols - 1) / 2.0),
                                       .cy_px = a->cy.value_or((left.rows - 1) / 2.0),
                                       .baseline_m = *a->baseline};
          }
          if (!a->cloud.empty() && !geometry)
            throw OptionError("--cloud needs metric geometry: give --calibration or --focal and --baseline");

          // The focal length lets the road model's tilt be checked and the refinement window follow the
          // road (as in the disparity stage).
          if (geometry) params.camera_focal_px = geometry->f_px;

          std::unique_ptr<tbb::global_control> limit;
          if (a->threads > 0) {
            limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a->threads);
            cv::setNumThreads(a->threads);
          }
          const DisparityResult res = ComputeDisparity(left, right, params);
          WriteKittiDisparityPng(a->output, res.disparity, res.valid);

          const RoadModel& m = res.road;
          fmt::print("pair            {}x{}\n", left.cols, left.rows);
          fmt::print("method          {} (requested {}){}\n",
                     res.method_used == DisparityMethod::kGptSgm ? "gpt-sgm" : "sgm", a->method,
                     res.fell_back ? ", FELL BACK to plain SGM: no reliable road model" : "");
          fmt::print("road model      d = {:.3f} + {:.5f} * (v cos(phi) - u sin(phi)), roll phi = {:.3f} deg\n", m.a0,
                     m.a1, m.roll_rad * 180 / M_PI);
          fmt::print("road fit        {} matches, {} inliers, RMS {:.3f} px, reliable: {}\n", m.num_matches,
                     m.num_inliers, m.residual_rms_px, m.reliable ? "yes" : "no");
          if (std::isfinite(res.road_tilt_rad))
            fmt::print("road tilt       {:.2f} deg across the image rows (bound {:.0f} deg){}\n",
                       res.road_tilt_rad * 180 / M_PI, params.max_road_tilt_deg,
                       res.road_tilt_rejected ? ": REJECTED" : "");
          if (res.method_used == DisparityMethod::kGptSgm)
            fmt::print("disparities     {} searched per pixel (residual range)\n", res.num_disparities);
          else
            fmt::print("disparities     {} searched per pixel, [{}, {})\n", res.num_disparities, res.min_disparity,
                       res.min_disparity + res.num_disparities);
          fmt::print("valid           {:.1f} % of pixels\n", 100 * res.valid_fraction);
          if (geometry && m.reliable) {
            const double d_centre = m.At(geometry->cx_px, geometry->cy_px);
            if (d_centre > 0)
              fmt::print(
                  "road range      {:.3f} m at the principal point (d = {:.2f} px, f = {:.1f} px, "
                  "B = {:.4f} m)\n",
                  geometry->f_px * geometry->baseline_m / d_centre, d_centre, geometry->f_px, geometry->baseline_m);
          }
          const DisparityTimings& t = res.timings;
          fmt::print(
              "timings [ms]    road model {:.1f}, warp {:.1f}, census {:.1f}, cost+aggregation {:.1f}, "
              "WTA+LR {:.1f}, post {:.1f}, transform {:.1f}, total {:.1f}\n",
              t.road_model_ms, t.warp_ms, t.census_ms, t.aggregation_ms, t.wta_ms, t.postprocess_ms, t.transform_ms,
              t.total_ms);
          fmt::print("wrote           {}\n", a->output);
          if (!a->transformed.empty()) {
            if (cv::countNonZero(res.transformed > 0) == 0)
              fmt::print(stderr, "warning: no reliable road model: the transformed disparity is empty\n");
            WriteTransformed(a->transformed, res.transformed);
            fmt::print("wrote           {} (transformed, road at {:.1f})\n", a->transformed, params.gpt_delta_px);
          }
          if (!a->preview.empty()) {
            const auto [lo, hi] = ValidRange(res.disparity, res.valid, 0.005, 0.995);
            if (!cv::imwrite(a->preview, ColorizeDisparity(res.disparity, res.valid, std::floor(lo), std::ceil(hi))))
              throw std::runtime_error(fmt::format("cannot write {}", a->preview));
            fmt::print("wrote           {} (preview, {:.0f}..{:.0f} px)\n", a->preview, std::floor(lo), std::ceil(hi));
          }
          if (!a->cloud.empty()) {
            const int64_t n = WriteCloudPly(a->cloud, res.disparity, res.valid, left, *geometry);
            fmt::print("wrote           {} ({} points, left camera frame, m)\n", a->cloud, n);
          }
          return kExitOk;
        };
      }};
}

}  // namespace rs
