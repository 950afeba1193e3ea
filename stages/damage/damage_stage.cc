#include "stages/damage/damage_stage.h"

#include <cmath>

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>

#include "formats/disparity/disparity_io.h"
#include "formats/image_file.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "stages/damage/cracks/crack_net.h"
#include "stages/damage/cracks/cracks.h"
#include "stages/damage/output/damage_output.h"
#include "survey/atomic_file.h"
#include "survey/hash.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

const OptionTable<DamageOptions>& DamageOptionsTable() {
  static const auto t = OptionTable<DamageOptions>()
                            .Include("road", &DamageOptions::road, RoadModelOptions::Table())
                            .Include("segment", &DamageOptions::segment, SegmentOptions::Table())
                            .Include("crack", &DamageOptions::crack, CrackOptions::Table())
                            .Include("measure", &DamageOptions::measure, MeasureOptions::Table())
                            .Include("severity", &DamageOptions::severity, SeverityOptions::Table());
  return t;
}

}  // namespace

void DamageStageOptions::Check() const {
  try {
    damage.Check();
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());
  }
}

const OptionTable<DamageStageOptions>& DamageStageOptions::Table() {
  static const auto t = OptionTable<DamageStageOptions>()
                            .Include("", &DamageStageOptions::damage, DamageOptionsTable())
                            .Add("write_overlay", &DamageStageOptions::write_overlay,
                                 "write an overlay PNG per frame (damage outlined and labelled on the left image)")
                            .Add("write_relief", &DamageStageOptions::write_relief,
                                 "write the transformed disparity and the depth below the road (float TIFFs) per frame")
                            .Add("skip_bad_frames", &DamageStageOptions::skip_bad_frames,
                                 "skip and count frames whose inputs cannot be read instead of failing");
  return t;
}

StageInfo DamageStage::Info() {
  StageInfo info;
  info.name = "damage";
  // 2: cracks carry outline_cam_m (their outline on the fitted road); 3: detections.json names
  // the crack detector (crack.detector: auto, learned, ridge, black-hat); 5: cracks one or two
  // pixels wide are measured (before, the outline smoothing erased them)
  info.version = 5;
  info.doc =
      "Per frame: robust 3-D road surface (obstacles removed), depth below the road, unsupervised damage "
      "segmentation, per-damage area, depth, volume, size, crack width/length, ASTM/FHWA severity.";
  info.inputs = {"frames", "calibration", "disparity"};
  info.outputs = {"damage"};
  info.published = {{"frames", "damage"}};
  info.per_frame = true;
  return info;
}

std::string DamageStage::ExtraKeyOf(const SurveyFile&, const DamageStageOptions& o) const {
  const CrackOptions& c = o.damage.crack;
  if (!c.enabled || ResolveCrackDetector(c, true, cv::Size()) != CrackOptions::Detector::kLearned) return {};
  const fs::path model = ResolveCrackModelPath(c.model);
  try {
    // The JSON beside the model holds its threshold and component rules: both change the output.
    return "crack_model_sha256=" + Sha256OfFile(model) +
           ";crack_model_json_sha256=" + Sha256OfFile(fs::path(model).replace_extension(".json"));
  } catch (const std::runtime_error&) {
    return "crack_model_missing=" + model.string();  // the run fails naming it
  }
}

void DamageStage::Run(StageContext& ctx, const DamageStageOptions& o) const {
  const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
  const StereoCalibration calib = ReadCalibrationYaml(ctx.input_dir("calibration") / "calibration.yaml");
  const RectifiedStereo geometry = RectifiedStereoOf(calib);
  const fs::path disparity_dir = ctx.input_dir("disparity");
  const std::string crack_detector =
      o.damage.crack.enabled ? CrackDetectorName(ResolveCrackDetector(o.damage.crack, true, cv::Size()), true) : "none";

  ctx.ForEachFrame(
      frames,
      [&](const FrameRecord& f, const fs::path& tmp) {
        const fs::path in_dir = StageContext::FrameDirIn(disparity_dir, f.id);
        if (fs::exists(in_dir / "skipped.json"))
          throw InputError(InputLocation::File((in_dir / "skipped.json").string()), "no disparity (frame skipped)");
        const cv::Mat disparity = ReadKittiDisparityPng(in_dir / disparity_files::kDisparity);
        // The disparity stage's second image (its small refinement window alone), where it wrote
        // one: the volumes are summed on it.
        const fs::path sharp_path = in_dir / disparity_files::kSharp;
        const cv::Mat sharp = fs::exists(sharp_path) ? ReadKittiDisparityPng(sharp_path) : cv::Mat();
        const cv::Mat left = LoadGray8(f.left);
        FrameDamage result;
        try {
          result = DetectDamage(disparity, left, geometry, o.damage, sharp);
        } catch (const std::invalid_argument& e) {
          // The algorithm rejects this frame's data (e.g. too few road points): a
          // counted skip with the reason, not a failed survey.
          throw InputError(InputLocation::File((in_dir / disparity_files::kDisparity).string()), e.what());
        }
        WriteLabelPng((tmp / "labels.png").string(), result.labels);
        if (!result.road_mask.empty()) WriteImageFile(tmp / "road.png", result.road_mask);
        nlohmann::json detections = {
            {"frame", f.id.value},
            {"t_ns", f.t_ns},
            {"threshold_sigma", result.threshold_sigma},
            {"crack_detector", crack_detector},
            // Damage farther than this was not looked for (null: no limit).
            {"analysed_range_m", std::isfinite(result.analysed_range_m) ? nlohmann::json(result.analysed_range_m)
                                                                        : nlohmann::json(nullptr)},
            {"road",
             {{"camera_height_m", result.surface.camera_height_m},
              {"residual_sigma_m", result.surface.residual_sigma_m},
              {"inliers", result.surface.inliers},
              {"obstacle_points", result.surface.obstacle_points}}}};
        detections.update(DetectionsToJson(result.instances));  // "schema" + "detections"
        WriteJsonAtomic(tmp / "detections.json", detections);
        if (o.write_overlay) WriteImageFile(tmp / "overlay.png", RenderOverlay(left, result.labels, result.instances));
        if (o.write_relief) {
          WriteImageFile(tmp / "transformed.tiff", result.relief.transformed_disparity_px);
          WriteImageFile(tmp / "depth_below_road_mm.tiff", result.relief.depth_below_mm);
        }
        FrameOutcome out;
        int potholes = 0, cracks = 0;
        for (const auto& d : result.instances) {
          potholes += d.type == DamageType::kPothole;
          cracks += d.type == DamageType::kCrack;
        }
        out.counts = {{"damages", result.instances.size()}, {"potholes", potholes}, {"cracks", cracks}};
        return out;
      },
      o.skip_bad_frames);
}

}  // namespace rs
