#include "formats/damage/detections_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

std::string Detection(const std::string& extra = "") {
  return R"({"id": 3, "type": "pothole", "pixel_count": 120, "area_m2": 0.2, "sigma_area_m2": 0.01,
    "max_depth_m": 0.04, "max_depth_seen_m": 0.035, "max_depth_bound_m": null, "mean_depth_m": 0.02,
    "volume_m3": 0.004, "volume_seen_m3": 0.004, "volume_upper_m3": null, "sigma_volume_m3": 0.0005,
    "equivalent_diameter_m": 0.5, "max_diameter_m": 0.6, "length_m": null, "mean_width_m": null,
    "max_width_m": null, "range_m": 3.0, "sigma_depth_m": 0.002, "confidence": 0.9, "floor_visible": true,
    "outline_px": [[1, 2], [3, 4], [5, 2]], "outline_cam_m": [[0.1, 0.2, 3.0], [0.2, 0.2, 3.0], [0.2, 0.3, 3.1]])" +
         extra + "}";
}

std::string File(const std::string& detection) {
  return R"({"schema": "roadsurvey.damage_detections/1", "frame": 7, "t_ns": 100, "detections": [)" + detection +
         "]}";
}

TEST(DetectionsFile, ReadsEveryField) {
  std::istringstream in(File(Detection()));
  const FrameDetections f = ReadFrameDetections(in, "d.json");
  EXPECT_EQ(f.frame, 7);
  EXPECT_EQ(f.t_ns, 100);
  ASSERT_EQ(f.detections.size(), 1u);
  const DamageDetection& d = f.detections[0];
  EXPECT_EQ(d.id, 3);
  EXPECT_EQ(d.type, "pothole");
  EXPECT_DOUBLE_EQ(d.max_depth_m, 0.04);
  EXPECT_TRUE(std::isnan(d.max_depth_bound_m));  // null: not measured
  EXPECT_TRUE(std::isnan(d.length_m));
  ASSERT_EQ(d.outline_px.size(), 3u);
  EXPECT_EQ(d.outline_px[1], Eigen::Vector2i(3, 4));
  ASSERT_EQ(d.outline_cam.size(), 3u);
  EXPECT_DOUBLE_EQ(d.outline_cam[2].z(), 3.1);
  EXPECT_TRUE(d.floor_visible);
  EXPECT_TRUE(std::isinf(f.analysed_range_m));  // not stated: no limit
}

TEST(DetectionsFile, AnalysedRange) {
  std::string text = File(Detection());
  text.replace(text.find("\"t_ns\""), 0, "\"analysed_range_m\": 9.5, ");
  std::istringstream in(text);
  EXPECT_DOUBLE_EQ(ReadFrameDetections(in, "d.json").analysed_range_m, 9.5);
  text.replace(text.find("9.5"), 3, "-1");
  std::istringstream bad(text);
  EXPECT_THROW(ReadFrameDetections(bad, "d.json"), InputError);
}

TEST(DetectionsFile, NamesTheFileAndTheMissingField) {
  std::string text = File(Detection());
  text.replace(text.find("\"range_m\""), 9, "\"range\"");
  std::istringstream in(text);
  try {
    ReadFrameDetections(in, "frames/000007/detections.json");
    FAIL() << "accepted a detection without range_m";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frames/000007/detections.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("range_m"), std::string::npos) << e.what();
  }
}

TEST(DetectionsFile, RejectsTruncatedAndForeignFiles) {
  const std::string text = File(Detection());
  std::istringstream cut(text.substr(0, text.size() / 2));
  EXPECT_THROW(ReadFrameDetections(cut, "d.json"), InputError);
  std::istringstream foreign(R"({"schema": "something/2", "frame": 1, "detections": []})");
  EXPECT_THROW(ReadFrameDetections(foreign, "d.json"), InputError);
}

}  // namespace
}  // namespace rs
