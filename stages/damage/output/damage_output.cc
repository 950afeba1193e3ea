#include "stages/damage/output/damage_output.h"

#include "stages/damage/measure/measure.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "formats/checked_file.h"
#include "formats/image_file.h"

namespace rs {
namespace {

nlohmann::json Num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json Grade(const SeverityGrade& g) {
  return {{"level", SeverityLevelName(g.level)}, {"equivalent_count", g.equivalent_count}, {"rule", g.rule}};
}

}  // namespace

void WriteLabelPng(const std::string& path, const cv::Mat& labels) {
  if (labels.type() != CV_16UC1) throw std::invalid_argument("WriteLabelPng: labels must be CV_16U");
  WriteImageFile(path, labels);
}

cv::Mat RenderOverlay(const cv::Mat& left, const cv::Mat& labels, const std::vector<DamageInstance>& instances) {
  if (left.empty() || left.depth() != CV_8U || labels.size() != left.size())
    throw std::invalid_argument("RenderOverlay: 8-bit image and labels of the same size required");
  cv::Mat out;
  if (left.channels() == 1)
    cv::cvtColor(left, out, cv::COLOR_GRAY2BGR);
  else
    out = left.clone();
  const int thick = std::max(2, left.cols / 500);
  const double font = std::max(0.5, left.cols / 1600.0);
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  for (const DamageInstance& d : instances) {
    const cv::Scalar colour = d.type == DamageType::kPothole ? cv::Scalar(0, 0, 255)
                              : d.type == DamageType::kCrack ? cv::Scalar(0, 255, 255)
                                                             : cv::Scalar(255, 0, 255);
    if (d.type == DamageType::kCrack) {
      if (d.id < static_cast<int>(boxes.size()) && !boxes[d.id].empty())
        out(boxes[d.id]).setTo(colour, labels(boxes[d.id]) == d.id);
    } else if (d.outline_px.size() >= 2) {
      cv::polylines(out, std::vector<std::vector<cv::Point>>{d.outline_px}, true, colour, thick, cv::LINE_AA);
    }
    std::string text = fmt::format("{} {}", d.id, DamageTypeName(d.type));
    if (d.type == DamageType::kCrack && std::isfinite(d.mean_width_m))
      text += fmt::format(" w{:.0f}mm {}", d.mean_width_m * 1000, SeverityLevelName(d.fhwa.level));
    else if (std::isfinite(d.max_depth_m) && (d.floor_visible || !std::isfinite(d.max_depth_bound_m)))
      text += fmt::format(" {:.0f}mm {}", d.max_depth_m * 1000, SeverityLevelName(d.astm.level));
    else if (std::isfinite(d.max_depth_m))  // the near rim hides the floor: the estimate "~" and its interval
      text += fmt::format(" ~{:.0f}mm [{:.0f}-{:.0f}] {}", d.max_depth_m * 1000,
                          std::max(0.0, d.max_depth_seen_m - 2 * d.sigma_depth_m) * 1000, d.max_depth_bound_m * 1000,
                          SeverityLevelName(d.astm.level));
    if (d.outline_px.empty()) continue;
    const cv::Rect box = cv::boundingRect(d.outline_px);
    const cv::Point at(box.x, std::max(20, box.y - 8));
    cv::putText(out, text, at, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thick + 2, cv::LINE_AA);
    cv::putText(out, text, at, cv::FONT_HERSHEY_SIMPLEX, font, colour, thick, cv::LINE_AA);
  }
  return out;
}

nlohmann::json DetectionsToJson(const std::vector<DamageInstance>& instances) {
  nlohmann::json list = nlohmann::json::array();
  for (const DamageInstance& d : instances) {
    nlohmann::json px = nlohmann::json::array(), cam = nlohmann::json::array();
    for (const cv::Point& p : d.outline_px) px.push_back({p.x, p.y});
    for (const cv::Point3d& p : d.outline_cam_m) cam.push_back({p.x, p.y, p.z});
    list.push_back({{"id", d.id},
                    {"type", DamageTypeName(d.type)},
                    {"pixel_count", d.pixel_count},
                    {"area_m2", Num(d.area_m2)},
                    {"max_depth_m", Num(d.max_depth_m)},
                    {"max_depth_seen_m", Num(d.max_depth_seen_m)},
                    {"mean_depth_m", Num(d.mean_depth_m)},
                    {"volume_m3", Num(d.volume_m3)},
                    {"volume_seen_m3", Num(d.volume_seen_m3)},
                    {"equivalent_diameter_m", Num(d.equivalent_diameter_m)},
                    {"max_diameter_m", Num(d.max_diameter_m)},
                    {"length_m", Num(d.length_m)},
                    {"mean_width_m", Num(d.mean_width_m)},
                    {"max_width_m", Num(d.max_width_m)},
                    {"range_m", Num(d.range_m)},
                    {"sigma_depth_m", Num(d.sigma_depth_m)},
                    {"sigma_area_m2", Num(d.sigma_area_m2)},
                    {"sigma_volume_m3", Num(d.sigma_volume_m3)},
                    {"confidence", Num(d.confidence)},
                    {"floor_visible", d.floor_visible},
                    {"grazing_angle_deg", Num(d.grazing_angle_deg)},
                    {"hidden_length_m", Num(d.hidden_length_m)},
                    {"max_depth_bound_m", Num(d.max_depth_bound_m)},
                    {"volume_upper_m3", Num(d.volume_upper_m3)},
                    {"astm_d6433", Grade(d.astm)},
                    {"fhwa_ltpp", Grade(d.fhwa)},
                    {"intervention", d.intervention},
                    {"intervention_rule", d.intervention_rule},
                    {"outline_px", px},
                    {"outline_cam_m", cam}});
  }
  return {{"schema", "roadsurvey.damage_detections/1"}, {"detections", list}};
}

void WriteDetectionsJson(const std::string& path, const std::vector<DamageInstance>& instances) {
  WriteFileChecked(path, DetectionsToJson(instances).dump(2) + "\n");
}

}  // namespace rs
