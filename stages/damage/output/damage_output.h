#pragma once
// Output helpers: 16-bit instance label PNG, overlay picture, detections JSON.

#include "stages/damage/damage_types.h"

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace rs {

/// Writes a CV_16U label image as a 16-bit PNG. Throws std::runtime_error naming the path on failure.
void WriteLabelPng(const std::string& path, const cv::Mat& labels);

/// The left image (grey or BGR, 8-bit) with every instance outlined (potholes red, cracks
/// yellow, other magenta) and labelled "<id> <type> <depth or width> <severity>".
cv::Mat RenderOverlay(const cv::Mat& left_image, const cv::Mat& labels, const std::vector<DamageInstance>& instances);

/// Detections as JSON: {"schema": "roadsurvey.damage_detections/1", "detections": [...]} with
/// every measurement (NaN written as null), both grades with their rules, and the outlines.
nlohmann::json DetectionsToJson(const std::vector<DamageInstance>& instances);

/// Writes DetectionsToJson to `path` (2-space indent). Throws std::runtime_error on failure.
void WriteDetectionsJson(const std::string& path, const std::vector<DamageInstance>& instances);

}  // namespace rs
