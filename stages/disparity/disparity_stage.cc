#include "stages/disparity/disparity_stage.h"

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "formats/disparity/disparity_io.h"
#include "formats/rectified_stereo.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

const OptionTable<RoadFitOptions>& RoadFitTable() {
  static const auto t =
      OptionTable<RoadFitOptions>()
          .Add("max_features", &RoadFitOptions::max_features, "strongest FAST corners kept per image")
          .Min(10)
          .Add("fast_threshold", &RoadFitOptions::fast_threshold, "FAST corner threshold", "grey levels")
          .Min(1)
          .Add("detect_scale", &RoadFitOptions::detect_scale, "detect and match on images resized by this")
          .Above(0)
          .Max(1)
          .Add("max_row_diff_px", &RoadFitOptions::max_row_diff_px, "epipolar constraint |v_left - v_right|", "px")
          .Min(0)
          .Add("min_disparity_px", &RoadFitOptions::min_disparity_px, "matches need a larger disparity", "px")
          .Add("max_disparity_px", &RoadFitOptions::max_disparity_px,
               "matches need at most this disparity (0 = the whole common field of view, below the image width)", "px")
          .Min(0)
          .Add("ratio", &RoadFitOptions::ratio, "Lowe ratio test on Hamming distances")
          .Above(0)
          .Max(1)
          .Add("max_hamming", &RoadFitOptions::max_hamming, "descriptor distance ceiling (of 256 bits)")
          .Min(0)
          .Max(256)
          .Add("ransac_iterations", &RoadFitOptions::ransac_iterations,
               "most planar hypotheses drawn (stops early at 99.99 % confidence)")
          .Min(1)
          .Add("inlier_threshold_px", &RoadFitOptions::inlier_threshold_px, "|d - model| for an inlier", "px")
          .Above(0)
          .Add("min_inliers", &RoadFitOptions::min_inliers, "fewer inliers: model unreliable, plain SGM fallback")
          .Min(3)
          .Add("min_inlier_fraction", &RoadFitOptions::min_inlier_fraction,
               "smaller inlier share of the matches: model unreliable")
          .Min(0)
          .Max(1)
          .Add("max_residual_rms_px", &RoadFitOptions::max_residual_rms_px, "larger inlier RMS: model unreliable", "px")
          .Above(0)
          .Add("quadratic", &RoadFitOptions::quadratic, "refine with a quadratic surface (cambered roads)")
          .Add("seed", &RoadFitOptions::seed, "RANSAC random seed (deterministic runs)");
  return t;
}

const OptionTable<DisparityParams>& ParamsTable() {
  static const auto t =
      OptionTable<DisparityParams>()
          .AddEnum("method", &DisparityParams::method,
                   {{"gpt-sgm", DisparityMethod::kGptSgm}, {"sgm", DisparityMethod::kSgm}},
                   "matcher: gpt-sgm (road model + perspective transformation + SGM) or plain sgm")
          .Add("min_disparity", &DisparityParams::min_disparity, "plain SGM (and fallback): smallest disparity", "px")
          .Add("num_disparities", &DisparityParams::num_disparities, "plain SGM (and fallback): disparities searched",
               "px")
          .Min(1)
          .Max(1024)
          .Add("presmooth_sigma_px", &DisparityParams::presmooth_sigma_px,
               "Gaussian blur of both images before the census (0 = off)", "px")
          .Min(0)
          .Add("census_width", &DisparityParams::census_width, "census window width (odd)", "px")
          .Min(1)
          .Add("census_height", &DisparityParams::census_height, "census window height (odd)", "px")
          .Min(1)
          .Add("ad_weight", &DisparityParams::ad_weight, "weight of the truncated absolute-difference cost (0 = off)")
          .Min(0)
          .Add("ad_truncation", &DisparityParams::ad_truncation, "truncation of |IL - IR|", "grey levels")
          .Min(1)
          .Add("num_paths", &DisparityParams::num_paths, "SGM aggregation paths (4 or 8)")
          .Add("p1", &DisparityParams::p1, "SGM penalty for +-1 px disparity changes")
          .Min(0)
          .Add("p2", &DisparityParams::p2, "SGM penalty for larger changes (p1 < p2)")
          .Min(0)
          .Add("adaptive_p2", &DisparityParams::adaptive_p2, "lower P2 at intensity edges")
          .Add("p2_gradient_scale", &DisparityParams::p2_gradient_scale, "g in the adaptive P2", "grey levels")
          .Min(1)
          .Add("uniqueness_ratio", &DisparityParams::uniqueness_ratio, "margin the best cost needs over others", "%")
          .Min(0)
          .Max(100)
          .AddEnum("subpixel", &DisparityParams::subpixel,
                   {{"equiangular", SubpixelMode::kEquiangular},
                    {"parabola", SubpixelMode::kParabola},
                    {"none", SubpixelMode::kNone}},
                   "sub-pixel refinement")
          .Add("lr_max_diff", &DisparityParams::lr_max_diff, "left-right consistency tolerance (< 0 disables)", "px")
          .Add("speckle_window_size", &DisparityParams::speckle_window_size,
               "drop connected regions smaller than this (0 = off)", "px")
          .Min(0)
          .Add("speckle_max_diff_px", &DisparityParams::speckle_max_diff_px, "disparity step inside a speckle region",
               "px")
          .Min(0)
          .Add("median", &DisparityParams::median, "3x3 median over valid neighbours")
          .Add("fill_min_neighbours", &DisparityParams::fill_min_neighbours,
               "fill an invalid pixel from its valid 3x3 neighbours when at least this many agree within "
               "speckle_max_diff_px (0 = off)")
          .Min(0)
          .Max(8)
          .Add("refine_window", &DisparityParams::refine_window,
               "window of the intensity sub-pixel refinement after SGM (odd; 0 = off: SGM's cost-curve sub-pixel only)",
               "px")
          .Min(0)
          .Max(31)
          .Add("refine_smooth_window", &DisparityParams::refine_smooth_window,
               "GPT-SGM: larger refinement window taken on the road and below where it agrees with refine_window's "
               "value (odd; 0 = off)",
               "px")
          .Min(0)
          .Max(63)
          .Add("refine_smooth_agree_px", &DisparityParams::refine_smooth_agree_px,
               "largest difference to refine_window's value where the smooth window's value is taken", "px")
          .Min(0)
          .Add("refine_max_coherence", &DisparityParams::refine_max_coherence,
               "with refine_smooth_window: pixels whose refine_window window is dominated by one straight, mostly "
               "vertical edge (structure-tensor coherence above this) take the smooth window's value computed without "
               "them (1 = off)")
          .Min(0)
          .Max(1)
          .Add("refine_highpass_px", &DisparityParams::refine_highpass_px,
               "box of the local mean subtracted from both images before the refinement (odd; the views' gain "
               "differs; a small box keeps the ramp it makes beside paint and shadow edges near the edge)",
               "px")
          .Min(3)
          .Max(63)
          .Add("refine_shift_ratio", &DisparityParams::refine_shift_ratio,
               "shiftable smooth windows: where the centred refine_smooth_window window's fit is this many times worse "
               "than the best same-sized window holding the pixel at its edge or corner (a depth change such as a "
               "pothole's wall), that window's value is taken (0 = off; else >= 1)")
          .Min(0)
          .Add("refine_ground_window", &DisparityParams::refine_ground_window,
               "GPT-SGM: refine_window's window shrinks in height to a square on the road (oblique views; its width "
               "kept, at least 5 rows; nadir views keep the square)")
          .Add("gpt_num_disparities", &DisparityParams::gpt_num_disparities,
               "GPT-SGM residual search range (road residual + damage depth)", "px")
          .Min(1)
          .Max(1024)
          .Add("gpt_delta_px", &DisparityParams::gpt_delta_px,
               "delta: residual disparity of the road's row minimum (damage down to -delta fits)", "px")
          .Min(0)
          .Add("gpt_headroom_px", &DisparityParams::gpt_headroom_px, "range kept above the road's largest residual",
               "px")
          .Min(0)
          .Add("gpt_expand_range", &DisparityParams::gpt_expand_range, "widen the GPT range when roll needs it")
          .Add("gpt_subpixel_warp", &DisparityParams::gpt_subpixel_warp,
               "warp the target by the exact sub-pixel shift (else whole-pixel row shifts)")
          .Add("gpt_pixel_warp", &DisparityParams::gpt_pixel_warp,
               "with gpt_subpixel_warp: shift each pixel by its road disparity (road residual = delta everywhere) "
               "instead of each row by its minimum")
          .Add("gpt_min_valid_fraction", &DisparityParams::gpt_min_valid_fraction,
               "fall back to plain SGM when a smaller share of the textured pixels whose road point is visible gets a "
               "valid GPT-SGM disparity")
          .Min(0)
          .Max(1)
          .Add("max_road_tilt_deg", &DisparityParams::max_road_tilt_deg,
               "GPT-SGM: reject a road model tilted further than this across the image rows (the rig's roll "
               "against the road; platform tilt <= 45 deg plus cross slope <= 5 deg), plain SGM instead (0 = off)",
               "deg")
          .Min(0)
          .Max(90)
          .Add("fallback_range_from_matches", &DisparityParams::fallback_range_from_matches,
               "GPT fallback: plain SGM over the sparse matches' disparity range (1st-99th percentile, widened) "
               "instead of [min_disparity, min_disparity + num_disparities)")
          .Include("road", &DisparityParams::road, RoadFitTable());
  return t;
}

cv::Mat LoadPair(const FrameRecord& f, cv::Mat* right) {
  cv::Mat left = LoadGray8(f.left);
  *right = LoadGray8(f.right);
  if (left.size() != right->size())
    throw InputError(
        InputLocation::File(f.right.string()),
        fmt::format("right image is {}x{}, left is {}x{}", right->cols, right->rows, left.cols, left.rows));
  return left;
}

// The temporal prior: the road model fitted on `previous`'s own pair, if reliable. A previous
// frame whose images cannot be read gives no prior (this frame is computed without one), so a
// bad frame is skipped alone and does not take the next good frame with it.
std::optional<RoadModel> PriorFromFrame(const FrameRecord& previous, const RoadFitOptions& road) {
  cv::Mat prev_right, prev_left;
  try {
    prev_left = LoadPair(previous, &prev_right);
  } catch (const InputError&) {
    return std::nullopt;
  }
  const auto samples = MatchSparseDisparities(prev_left, prev_right, road);
  const RoadModel m = FitRoadModel(samples, prev_left.cols, prev_left.rows, road);
  if (!m.reliable) return std::nullopt;
  return m;
}

nlohmann::json RoadModelJson(const RoadModel& m, const DisparityResult& r, double delta_px) {
  return {{"a0", m.a0},
          {"a1", m.a1},
          {"roll_rad", m.roll_rad},
          {"c", m.c},
          {"quadratic", m.quadratic},
          {"delta_px", delta_px},
          {"matches", m.num_matches},
          {"inliers", m.num_inliers},
          {"residual_rms_px", m.residual_rms_px},
          {"reliable", m.reliable},
          {"from_prior", m.from_prior},
          {"method_used", r.method_used == DisparityMethod::kGptSgm ? "gpt-sgm" : "sgm"},
          {"fell_back", r.fell_back},
          {"min_disparity", r.min_disparity},
          {"num_disparities", r.num_disparities},
          // Lateral tilt (RoadLateralTiltRad) of the sparse model; null without a focal length.
          {"lateral_tilt_rad", std::isfinite(r.road_tilt_rad) ? nlohmann::json(r.road_tilt_rad) : nlohmann::json()},
          {"tilt_rejected", r.road_tilt_rejected},
          {"valid_fraction", r.valid_fraction}};  // timings go to the run summary: outputs stay reproducible
}

}  // namespace

void DisparityStageOptions::Check() const {
  try {
    params.Check();
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());
  }
}

const OptionTable<DisparityStageOptions>& DisparityStageOptions::Table() {
  static const auto t =
      OptionTable<DisparityStageOptions>()
          .Include("", &DisparityStageOptions::params, ParamsTable())
          .Add("temporal_prior", &DisparityStageOptions::temporal_prior,
               "seed each frame's road fit with the previous frame's model (helps high, weakly textured flights)")
          .Add("write_transformed", &DisparityStageOptions::write_transformed,
               "write the transformed disparity (float TIFF), which the damage stage reads")
          .Add("write_sharp", &DisparityStageOptions::write_sharp,
               "write disparity_sharp.png (KITTI 16-bit) where the smooth refinement window ran: the refine_window "
               "value alone, on which the damage stage sums volumes")
          .Add("write_preview", &DisparityStageOptions::write_preview, "write a colour preview PNG per frame")
          .Add("write_point_cloud", &DisparityStageOptions::write_point_cloud,
               "write a metric point cloud PLY per frame (left camera frame)")
          .Add("skip_bad_frames", &DisparityStageOptions::skip_bad_frames,
               "skip and count frames whose images cannot be read instead of failing");
  return t;
}

StageInfo DisparityStage::Info() {
  StageInfo info;
  info.name = "disparity";
  // 2: a frame whose predecessor is unreadable is computed without the temporal prior; 3: road keypoints
  // matched over the whole common field of view, tilt check, fallback range from the matches.
  info.version = 3;
  info.doc =
      "Dense road disparity per frame: GPT-SGM (road model, perspective transformation, semi-global "
      "matching over a small residual range), plain SGM where the road model is unreliable.";
  info.inputs = {"frames", "calibration"};
  info.outputs = {"disparity"};
  info.published = {{"frames", "disparity"}};
  info.per_frame = true;
  return info;
}

void DisparityStage::Run(StageContext& ctx, const DisparityStageOptions& o) const {
  const fs::path ingest = ctx.input_dir("frames");
  const auto frames = ReadFrameIndex(ingest / "frames.csv");
  const StereoCalibration calib = ReadCalibrationYaml(ctx.input_dir("calibration") / "calibration.yaml");
  std::map<int64_t, const FrameRecord*> previous;
  for (size_t i = 1; i < frames.size(); ++i) previous[frames[i].id.value] = &frames[i - 1];

  ctx.ForEachFrame(
      frames,
      [&](const FrameRecord& f, const fs::path& tmp) {
        cv::Mat right;
        const cv::Mat left = LoadPair(f, &right);
        // The prior is fitted from the previous frame's own pair, so every frame's
        // result is independent of processing order (parallel, resumable, cacheable).
        std::optional<RoadModel> prior;
        if (o.temporal_prior && o.params.method == DisparityMethod::kGptSgm && previous.count(f.id.value))
          prior = PriorFromFrame(*previous[f.id.value], o.params.road);
        DisparityParams params = o.params;
        params.camera_focal_px = calib.left.fx;
        const DisparityResult r = ComputeDisparity(left, right, params, prior ? &*prior : nullptr);
        WriteKittiDisparityPng((tmp / disparity_files::kDisparity).string(), r.disparity, r.valid);
        WriteImageChecked((tmp / disparity_files::kValid).string(), r.valid);
        if (o.write_sharp && !r.disparity_sharp.empty())
          WriteKittiDisparityPng((tmp / disparity_files::kSharp).string(), r.disparity_sharp, r.valid);
        if (o.write_transformed && !r.transformed.empty())
          WriteImageChecked((tmp / disparity_files::kTransformed).string(), r.transformed);
        if (o.write_preview) {
          double d_max = 0;
          cv::minMaxLoc(r.disparity, nullptr, &d_max, nullptr, nullptr, r.valid);
          WriteImageChecked((tmp / disparity_files::kPreview).string(),
                            ColorizeDisparity(r.disparity, r.valid, 0, d_max));
        }
        if (o.write_point_cloud)
          WriteDisparityPointCloud((tmp / disparity_files::kPointCloud).string(), r.disparity, r.valid, left,
                                   RectifiedStereoOf(calib));
        WriteJsonAtomic(tmp / disparity_files::kRoadModel, RoadModelJson(r.road, r, o.params.gpt_delta_px));
        FrameOutcome out;
        out.counts = {{"fell_back", r.fell_back ? 1 : 0},
                      {"valid_fraction_sum", r.valid_fraction},
                      {"road_inliers_sum", r.road.num_inliers},
                      {"compute_ms_sum", r.timings.total_ms}};
        if (r.fell_back && r.road_tilt_rejected)
          out.warnings.push_back(fmt::format(
              "road model tilted {:.1f} deg across the image rows (bound {:g}): plain SGM over [{}, {})",
              r.road_tilt_rad * 180 / M_PI, o.params.max_road_tilt_deg, r.min_disparity,
              r.min_disparity + r.num_disparities));
        else if (r.fell_back)
          out.warnings.push_back(fmt::format("road model unreliable ({} inliers): plain SGM over [{}, {})",
                                             r.road.num_inliers, r.min_disparity, r.min_disparity + r.num_disparities));
        return out;
      },
      o.skip_bad_frames);
}

}  // namespace rs
