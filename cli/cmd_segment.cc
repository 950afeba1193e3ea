// roadsurvey segment TRANSFORMED -o LABELS.png: the damage stage's unsupervised segmentation on
// a transformed disparity image of any scale (ours from `roadsurvey stereo --transformed`, or a
// foreign one such as fan2019's disp_tg). No metric values: a transformed disparity has lost
// the road disparity that depth in metres needs.
#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "cli/tool_util.h"
#include "formats/input_error.h"
#include "formats/stereo/image_io.h"
#include "stages/damage/output/damage_output.h"
#include "stages/damage/cracks/cracks.h"
#include "stages/damage/damage_pipeline.h"

namespace rs {
namespace {

/// Grey picture of the relief for overlays without a left image: road level mid-grey, the
/// segmentation threshold (and deeper) black.
cv::Mat ReliefPicture(const cv::Mat& transformed, const ReliefScale& scale, double threshold_sigma) {
  cv::Mat value;
  transformed.convertTo(value, CV_32F);
  const double span = std::max(1e-9, threshold_sigma * scale.sigma);
  cv::Mat grey;
  value.convertTo(grey, CV_8U, 128.0 / span, 128.0 - 128.0 * scale.road_level / span);
  grey.setTo(0, value <= 0);
  return grey;
}

}  // namespace

Command SegmentCommand() {
  return {"segment", "Segment road damage in a transformed disparity image -> 16-bit instance labels",
          [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
            app.option_defaults()->always_capture_default();
            struct Args {
              std::string input, output, image, overlay, json;
              bool no_cracks = false;
              int min_area_px = SegmentOptions{}.min_area_px;
              double min_threshold_sigma = SegmentOptions{}.min_threshold_sigma;
              int level_cell_px = SegmentOptions{}.level_cell_px;
              double min_wall_steepness = SegmentOptions{}.min_wall_steepness;
              std::optional<double> road_level, sigma;
            };
            auto a = std::make_shared<Args>();
            app.add_option("transformed", a->input,
                           "transformed disparity: 8/16-bit PNG or float TIFF, any scale; 0 (float: <= 0) = invalid")
                ->required();
            app.add_option("-o,--output", a->output, "instance labels, 16-bit PNG (0 = none, 1..n = instance id)")
                ->required();
            app.add_option("--image", a->image,
                           "left image (same size): enables crack detection; the overlay is drawn on it");
            app.add_option(
                "--overlay", a->overlay,
                "picture with every instance outlined and labelled (on --image, else on the relief in grey)");
            app.add_option("--json", a->json, "detections JSON (roadsurvey.damage_detections/1)");
            app.add_flag("--no-cracks", a->no_cracks, "skip crack detection in --image");
            app.add_option("--min-area-px", a->min_area_px, "smallest damage kept, px")->check(CLI::PositiveNumber);
            app.add_option("--min-threshold-sigma", a->min_threshold_sigma,
                           "threshold at least this many robust sigma below the road level");
            app.add_option("--level-cell-px", a->level_cell_px,
                           "cell of the local road level that follows ruts, sags and a crown (0 = one level)")
                ->check(CLI::NonNegativeNumber);
            app.add_option("--min-wall-steepness", a->min_wall_steepness,
                           "a depression's wall slope at least this many road slope-noise sigma (0 = off)")
                ->check(CLI::NonNegativeNumber);
            auto* level = app.add_option("--road-level", a->road_level,
                                         "road level in the image's units (default: estimated, histogram mode; "
                                         "the local level then follows the road's shape from it)");
            auto* sigma = app.add_option("--sigma", a->sigma, "road noise in the image's units (with --road-level)")
                              ->check(CLI::PositiveNumber);
            level->needs(sigma);
            sigma->needs(level);
            auto flags = std::make_shared<OptionFlags>();
            flags->Add(app, "segment", SegmentOptions::Table(), "Segmentation options (the damage stage's segment.*)",
                       {"min_area_px", "min_threshold_sigma", "level_cell_px", "min_wall_steepness"});
            return [a, flags] {
              DamageOptions options;
              options.segment.min_area_px = a->min_area_px;
              options.segment.min_threshold_sigma = a->min_threshold_sigma;
              options.segment.level_cell_px = a->level_cell_px;
              options.segment.min_wall_steepness = a->min_wall_steepness;
              if (const nlohmann::json overrides = flags->Overrides(); overrides.contains("segment")) {
                const auto& table = SegmentOptions::Table();
                options.segment =
                    table.FromJson(table.Merge(overrides["segment"], "segment", table.ToJson(options.segment)));
              }
              options.crack.enabled = !a->no_cracks;
              CheckAsOption([&] { options.Check(); });
              const cv::Mat transformed = ReadImageAnyDepth(a->input, true);
              cv::Mat left;
              if (!a->image.empty()) {
                left = LoadColor8(a->image);
                if (left.size() != transformed.size())
                  throw InputError(InputLocation::File(a->image),
                                   fmt::format("size {}x{} differs from the transformed disparity's {}x{}", left.cols,
                                               left.rows, transformed.cols, transformed.rows));
              }
              std::optional<ReliefScale> scale;
              if (a->road_level) scale = ReliefScale{*a->road_level, *a->sigma};
              TransformedSegmentation seg;
              try {
                seg = SegmentTransformedDisparity(transformed, left, options, scale);
              } catch (const std::invalid_argument& e) {  // unsupported depth, too few valid pixels: the input
                throw InputError(InputLocation::File(a->input), e.what());
              }
              WriteLabelPng(a->output, seg.labels);

              int potholes_other = 0, cracks = 0;
              for (const auto& d : seg.instances) (d.type == DamageType::kCrack ? cracks : potholes_other)++;
              fmt::print("input           {} ({}x{})\n", a->input, transformed.cols, transformed.rows);
              fmt::print("road level      {:.4g} (sigma {:.4g}){}\n", seg.scale.road_level, seg.scale.sigma,
                         scale ? ", given" : ", estimated");
              fmt::print("threshold       {:.2f} sigma below the road\n", seg.threshold_sigma);
              fmt::print(
                  "instances       {} depressions, {} cracks (metric values unknown: a transformed "
                  "disparity carries no depth in metres)\n",
                  potholes_other, cracks);
              if (options.crack.enabled && !left.empty())
                fmt::print("crack detector  {}\n",
                           CrackDetectorName(ResolveCrackDetector(options.crack, false, left.size()), false));
              if (!seg.instances.empty()) {
                fmt::print("\n{:>4} {:<8} {:>9} {:>11} {:>22}\n", "id", "type", "pixels", "confidence",
                           "bbox (u, v, w, h)");
                for (const auto& d : seg.instances) {
                  const cv::Rect box = d.outline_px.empty() ? cv::Rect() : cv::boundingRect(d.outline_px);
                  fmt::print("{:>4} {:<8} {:>9} {:>11.2f} {:>22}\n", d.id, DamageTypeName(d.type), d.pixel_count,
                             d.confidence, fmt::format("{}, {}, {}, {}", box.x, box.y, box.width, box.height));
                }
                fmt::print("\n");
              }
              fmt::print("wrote           {}\n", a->output);
              if (!a->json.empty()) {
                WriteDetectionsJson(a->json, seg.instances);
                fmt::print("wrote           {}\n", a->json);
              }
              if (!a->overlay.empty()) {
                const cv::Mat base = left.empty() ? ReliefPicture(transformed, seg.scale, seg.threshold_sigma) : left;
                if (!cv::imwrite(a->overlay, RenderOverlay(base, seg.labels, seg.instances)))
                  throw std::runtime_error(fmt::format("cannot write {}", a->overlay));
                fmt::print("wrote           {}\n", a->overlay);
              }
              return kExitOk;
            };
          }};
}

}  // namespace rs
