#include "eval/damage_map/damage_map_eval.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

using nlohmann::json;

const EnuOrigin kOrigin{48.137, 11.575, 520.0};

geojson::Position LonLat(double x_east_m, double y_north_m) {
  static const GeographicLib::LocalCartesian enu(kOrigin.lat_deg, kOrigin.lon_deg, kOrigin.h_ellipsoid_m);
  double lat, lon, h;
  enu.Reverse(x_east_m, y_north_m, 0, lat, lon, h);
  return {lon, lat, std::nullopt};
}

// A 64-gon of radius r around (cx, cy), ENU metres.
geojson::Feature Circle(double cx, double cy, double r, json properties) {
  geojson::Ring ring;
  for (int k = 0; k < 64; ++k) {
    const double a = 2 * std::numbers::pi * k / 64;
    ring.push_back(LonLat(cx + r * std::cos(a), cy + r * std::sin(a)));
  }
  return {geojson::Polygon{{ring}}, std::move(properties)};
}

geojson::Feature Line(double x0, double y0, double x1, double y1, json properties) {
  return {geojson::LineString{{LonLat(x0, y0), LonLat(x1, y1)}}, std::move(properties)};
}

json TruthPothole(int id, double r, double depth_m = 0.05) {
  const double area = std::numbers::pi * r * r;
  return {{"id", id},
          {"type", "pothole"},
          {"area_m2", area},
          {"max_depth_m", depth_m},
          {"volume_m3", 0.4 * area * depth_m},
          {"mean_diameter_m", 2 * r}};
}

json TruthCrack(int id, double length_m) {
  return {{"id", id}, {"type", "crack_longitudinal"}, {"length_m", length_m}, {"width_m", 0.005}};
}

json Predicted(int id, const char* type) {
  return {{"id", id},
          {"type", type},
          {"area_m2", nullptr},
          {"sigma_area_m2", nullptr},
          {"max_depth_m", nullptr},
          {"sigma_max_depth_m", nullptr},
          {"volume_m3", nullptr},
          {"floor_visible", nullptr},
          {"chainage_m", 1.5},
          {"offset_m", -0.25}};
}

TruthSightings Seen(std::initializer_list<int> whole, std::initializer_list<int> partial) {
  TruthSightings s;
  for (int id : whole) s[id] = {2, 1, 400};
  for (int id : partial) s[id] = {0, 3, 400};
  return s;
}

// Intersection over union of two discs of radius r whose centres are d apart.
double DiscIou(double r, double d) {
  const double inter = 2 * r * r * std::acos(d / (2 * r)) - 0.5 * d * std::sqrt(4 * r * r - d * d);
  return inter / (2 * std::numbers::pi * r * r - inter);
}

const PotholeMatch* MatchOfTruth(const DamageMapEvaluation& e, int truth_id) {
  for (const auto& m : e.pothole_matches)
    if (m.truth_id == truth_id) return &m;
  return nullptr;
}

TEST(DamageMapEval, PotholesMatchesDuplicatesMissesAndFalsePositives) {
  geojson::FeatureCollection truth, pred;
  truth.features.push_back(Circle(0, 0, 0.25, TruthPothole(1, 0.25)));
  truth.features.push_back(Circle(3, 0, 0.25, TruthPothole(2, 0.25)));
  truth.features.push_back(Circle(6, 0, 0.25, TruthPothole(3, 0.25)));   // missed (mapped as "other")
  truth.features.push_back(Circle(9, 0, 0.10, TruthPothole(4, 0.10)));   // smaller than 0.3 m
  truth.features.push_back(Circle(12, 0, 0.25, TruthPothole(5, 0.25)));  // never seen whole
  truth.features.push_back(Circle(15, 0, 0.25, TruthPothole(6, 0.25)));  // never seen
  truth.features.push_back(Circle(30, 0, 1.0, {{"id", 7}, {"type", "patch"}, {"area_m2", 3.1}}));

  // 10 on truth 1, 2 cm east, floor seen: depth +5 mm (within 2σ = 8 mm), area +7 % (outside 2σ).
  json p10 = Predicted(10, "pothole");
  const double a1 = TruthPothole(1, 0.25)["area_m2"].get<double>();
  const double v1 = TruthPothole(1, 0.25)["volume_m3"].get<double>();
  p10.update({{"max_depth_m", 0.055},
              {"sigma_max_depth_m", 0.004},
              {"area_m2", 1.07 * a1},
              {"sigma_area_m2", 0.01 * a1},
              {"volume_m3", 0.9 * v1},
              {"sigma_volume_m3", 0.1 * v1},
              {"floor_visible", true}});
  pred.features.push_back(Circle(0.02, 0, 0.25, p10));
  // 11 on truth 2 with the floor hidden: the true depth lies in [seen, bound], the volume above the upper bound.
  json p11 = Predicted(11, "pothole");
  p11.update({{"max_depth_m", 0.045},
              {"floor_visible", false},
              {"max_depth_seen_m", 0.04},
              {"max_depth_bound_m", 0.06},
              {"volume_upper_m3", 0.5 * v1}});
  pred.features.push_back(Circle(3, 0, 0.25, p11));
  pred.features.push_back(Circle(3.05, 0, 0.15, Predicted(12, "pothole")));  // inside truth 2: duplicate
  pred.features.push_back(Circle(9, 0, 0.10, Predicted(13, "pothole")));     // on the small truth 4
  pred.features.push_back(Circle(12, 0, 0.25, Predicted(14, "pothole")));    // on the partial truth 5
  pred.features.push_back(Circle(20, 0, 0.25, Predicted(15, "pothole")));    // on nothing
  pred.features.push_back(Circle(15, 0, 0.25, Predicted(16, "pothole")));    // on truth 6, which no frame saw
  pred.features.push_back(Circle(6, 0, 0.25, Predicted(17, "other")));

  const DamageMapEvaluation e = ScoreDamageMap(truth, pred, kOrigin, Seen({1, 2, 3, 4, 7}, {5}), {});
  const DamageTypeCounts& c = e.potholes;
  EXPECT_EQ(c.truth, 6);
  EXPECT_EQ(c.seen, 3);
  EXPECT_EQ(c.small, 1);
  EXPECT_EQ(c.partial, 1);
  EXPECT_EQ(c.unseen, 1);
  EXPECT_EQ(c.predicted, 7);
  EXPECT_EQ(c.matched, 2);
  EXPECT_EQ(c.unscored, 2);
  EXPECT_EQ(c.duplicates, 1);
  EXPECT_EQ(c.false_positives, 2);
  EXPECT_EQ(c.misses, 1);
  EXPECT_NEAR(c.recall, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(c.precision, 2.0 / 5.0, 1e-12);
  EXPECT_EQ(e.predicted_other, 1);
  EXPECT_EQ(e.other_truth.at("patch").truth, 1);
  EXPECT_EQ(e.other_truth.at("patch").seen, 1);

  ASSERT_EQ(e.pothole_duplicates.size(), 1u);
  EXPECT_EQ(e.pothole_duplicates[0].predicted_id, 12);
  EXPECT_EQ(e.pothole_duplicates[0].truth_id, 2);
  EXPECT_NEAR(e.pothole_duplicates[0].overlap, 1.0, 0.02);

  ASSERT_EQ(e.pothole_misses.size(), 1u);
  EXPECT_EQ(e.pothole_misses[0].truth_id, 3);
  EXPECT_EQ(e.pothole_misses[0].frames_whole, 2);
  EXPECT_EQ(e.pothole_misses[0].typed_otherwise_id, 17);
  EXPECT_EQ(e.pothole_misses[0].typed_otherwise_as, "other");

  ASSERT_EQ(e.pothole_false_positives.size(), 2u);
  EXPECT_EQ(e.pothole_false_positives[0].predicted_id, 15);
  EXPECT_NEAR(e.pothole_false_positives[0].centroid_enu_m.x, 20, 1e-3);
  EXPECT_NEAR(e.pothole_false_positives[0].centroid_enu_m.y, 0, 1e-3);
  EXPECT_DOUBLE_EQ(e.pothole_false_positives[0].chainage_m, 1.5);
  EXPECT_EQ(e.pothole_false_positives[1].predicted_id, 16);
  EXPECT_EQ(e.pothole_false_positives[1].nearest_truth_id, 6);
  EXPECT_DOUBLE_EQ(e.pothole_false_positives[1].nearest_truth_distance_m, 0);

  ASSERT_EQ(e.pothole_matches.size(), 4u);  // 10, 11 scored; 13, 14 unscored
  const PotholeMatch* m1 = MatchOfTruth(e, 1);
  ASSERT_NE(m1, nullptr);
  EXPECT_EQ(m1->predicted_id, 10);
  EXPECT_TRUE(m1->scored);
  EXPECT_NEAR(m1->centroid_error_m, 0.02, 1e-4);
  EXPECT_NEAR(m1->iou, DiscIou(0.25, 0.02), 0.01);
  EXPECT_NEAR(m1->depth_error_mm, 5.0, 1e-6);
  EXPECT_EQ(m1->depth_within_uncertainty, true);
  EXPECT_NEAR(m1->area_error_pct, 7.0, 1e-6);
  EXPECT_EQ(m1->area_within_uncertainty, false);
  EXPECT_NEAR(m1->volume_error_pct, -10.0, 1e-6);
  EXPECT_EQ(m1->volume_within_uncertainty, true);

  const PotholeMatch* m2 = MatchOfTruth(e, 2);
  ASSERT_NE(m2, nullptr);
  EXPECT_EQ(m2->predicted_id, 11);
  EXPECT_NEAR(m2->iou, 1.0, 1e-3);
  EXPECT_EQ(m2->floor_visible, false);
  EXPECT_EQ(m2->depth_within_uncertainty, true);          // 0.05 in [0.04, 0.06]
  EXPECT_EQ(m2->volume_within_uncertainty, false);        // truth above volume_upper_m3
  EXPECT_FALSE(m2->area_within_uncertainty.has_value());  // no area stated
  EXPECT_TRUE(std::isnan(m2->area_error_pct));

  ASSERT_NE(MatchOfTruth(e, 4), nullptr);
  EXPECT_FALSE(MatchOfTruth(e, 4)->scored);
  ASSERT_NE(MatchOfTruth(e, 5), nullptr);
  EXPECT_EQ(MatchOfTruth(e, 5)->predicted_id, 14);

  // Summaries over the two scored matches.
  EXPECT_EQ(e.floor_hidden, 1);
  EXPECT_EQ(e.depth_error_mm.n, 2);
  EXPECT_NEAR(e.depth_error_mm.median_abs, 5.0, 1e-6);
  EXPECT_NEAR(e.depth_error_mm.max_abs, 5.0, 1e-6);
  EXPECT_EQ(e.depth_error_mm.within_tolerance, 2);
  EXPECT_EQ(e.depth_error_mm.judged, 2);
  EXPECT_EQ(e.depth_error_mm.within_uncertainty, 2);
  EXPECT_EQ(e.area_error_pct.n, 1);
  EXPECT_EQ(e.area_error_pct.within_tolerance, 1);
  EXPECT_EQ(e.area_error_pct.within_uncertainty, 0);
  EXPECT_EQ(e.volume_error_pct.judged, 2);
  EXPECT_EQ(e.volume_error_pct.within_uncertainty, 1);
  EXPECT_EQ(e.iou.n, 2);

  const json j = e.ToJson();
  EXPECT_EQ(j["schema"], "roadsurvey.eval_damage_map/1");
  EXPECT_EQ(j["potholes"]["counts"]["matched"], 2);
  EXPECT_EQ(j["potholes"]["false_positives"][0]["predicted_id"], 15);
  EXPECT_TRUE(j["potholes"]["matches"][1]["area_error_pct"].is_null());
  EXPECT_EQ(j["options"]["min_overlap"], 0.3);
  const std::string table = e.Table();
  EXPECT_NE(table.find("pothole"), std::string::npos);
  EXPECT_NE(table.find("mapped as other 17"), std::string::npos);
}

TEST(DamageMapEval, OverlapThresholdIsOnTheSmallerArea) {
  geojson::FeatureCollection truth, pred;
  truth.features.push_back(Circle(0, 0, 0.5, TruthPothole(1, 0.5)));
  // A disc of r = 0.2 centred on the truth's rim: intersection / its own area = 0.457 ≥ 0.3 (two
  // circles' lens), although the IoU is 0.067.
  pred.features.push_back(Circle(0.5, 0, 0.2, Predicted(10, "pothole")));
  // A disc touching the truth by a sliver: below the threshold.
  pred.features.push_back(Circle(-0.68, 0, 0.2, Predicted(11, "pothole")));
  const DamageMapEvaluation e = ScoreDamageMap(truth, pred, kOrigin, Seen({1}, {}), {});
  EXPECT_EQ(e.potholes.matched, 1);
  ASSERT_EQ(e.pothole_matches.size(), 1u);
  EXPECT_EQ(e.pothole_matches[0].predicted_id, 10);
  EXPECT_NEAR(e.pothole_matches[0].overlap, 0.457, 0.01);
  EXPECT_LT(e.pothole_matches[0].iou, 0.1);
  EXPECT_EQ(e.potholes.false_positives, 1);

  DamageMapEvalOptions strict;
  strict.min_overlap = 0.6;
  EXPECT_EQ(ScoreDamageMap(truth, pred, kOrigin, Seen({1}, {}), strict).potholes.matched, 0);
}

TEST(DamageMapEval, CracksCoverageDuplicatesAndMisses) {
  geojson::FeatureCollection truth, pred;
  truth.features.push_back(Line(0, 5, 2, 5, TruthCrack(20, 2.0)));
  truth.features.push_back(Line(0, 8, 2, 8, TruthCrack(21, 2.0)));    // missed
  truth.features.push_back(Line(5, 5, 5.3, 5, TruthCrack(22, 0.3)));  // shorter than 0.5 m
  truth.features.push_back(Line(10, 5, 12, 5, TruthCrack(23, 2.0)));  // never seen whole
  json p30 = Predicted(30, "crack");
  p30["length_m"] = 1.6;
  // 5 cm beside the first 1.6 m: covers x in [0, 1.6 + √(0.1² − 0.05²)] of 2 m.
  pred.features.push_back(Line(0, 5.05, 1.6, 5.05, p30));
  pred.features.push_back(Line(0.9, 5.0, 2.0, 5.0, Predicted(31, "crack")));  // covers 60 %: duplicate
  pred.features.push_back(Line(0, 12, 1, 12, Predicted(32, "crack")));        // on nothing
  pred.features.push_back(Line(5, 5, 5.3, 5, Predicted(33, "crack")));        // on the short truth
  pred.features.push_back(Line(0, 8, 0.6, 8, Predicted(34, "crack")));        // 30 % of truth 21: no match
  pred.features.push_back(Line(10, 5, 12, 5, Predicted(35, "crack")));        // on the partial truth

  const DamageMapEvaluation e = ScoreDamageMap(truth, pred, kOrigin, Seen({20, 21, 22}, {23}), {});
  const DamageTypeCounts& c = e.cracks;
  EXPECT_EQ(c.truth, 4);
  EXPECT_EQ(c.seen, 2);
  EXPECT_EQ(c.small, 1);
  EXPECT_EQ(c.partial, 1);
  EXPECT_EQ(c.matched, 1);
  EXPECT_EQ(c.unscored, 2);
  EXPECT_EQ(c.duplicates, 1);
  EXPECT_EQ(c.false_positives, 2);
  EXPECT_EQ(c.misses, 1);
  EXPECT_NEAR(c.recall, 0.5, 1e-12);
  EXPECT_NEAR(c.precision, 0.25, 1e-12);

  const CrackMatch* m = nullptr;
  for (const auto& k : e.crack_matches)
    if (k.truth_id == 20) m = &k;
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->predicted_id, 30);
  EXPECT_NEAR(m->coverage, (1.6 + std::sqrt(0.1 * 0.1 - 0.05 * 0.05)) / 2.0, 0.01);
  EXPECT_NEAR(m->length_error_pct, -20.0, 1e-6);
  ASSERT_EQ(e.crack_duplicates.size(), 1u);
  EXPECT_EQ(e.crack_duplicates[0].predicted_id, 31);
  EXPECT_NEAR(e.crack_duplicates[0].overlap, 0.6, 0.01);
  ASSERT_EQ(e.crack_misses.size(), 1u);
  EXPECT_EQ(e.crack_misses[0].truth_id, 21);
  ASSERT_EQ(e.crack_false_positives.size(), 2u);
  EXPECT_EQ(e.crack_false_positives[0].predicted_id, 32);
  EXPECT_EQ(e.crack_false_positives[1].predicted_id, 34);
  EXPECT_EQ(e.crack_false_positives[1].nearest_truth_id, 21);
  EXPECT_NEAR(e.crack_false_positives[1].nearest_truth_distance_m, 0, 1e-3);
  EXPECT_EQ(e.crack_length_error_pct.n, 1);
}

TEST(DamageMapEval, CrackToleranceIsADistance) {
  geojson::FeatureCollection truth, near, far;
  truth.features.push_back(Line(0, 0, 1, 0, TruthCrack(1, 1.0)));
  near.features.push_back(Line(0, 0.09, 1, 0.09, Predicted(2, "crack")));
  far.features.push_back(Line(0, 0.11, 1, 0.11, Predicted(2, "crack")));
  const DamageMapEvaluation a = ScoreDamageMap(truth, near, kOrigin, Seen({1}, {}), {});
  const DamageMapEvaluation b = ScoreDamageMap(truth, far, kOrigin, Seen({1}, {}), {});
  ASSERT_EQ(a.crack_matches.size(), 1u);
  EXPECT_NEAR(a.crack_matches[0].coverage, 1.0, 1e-9);
  EXPECT_TRUE(std::isnan(a.crack_matches[0].length_error_pct));  // the map gave no length
  EXPECT_EQ(b.cracks.matched, 0);
  EXPECT_EQ(b.cracks.false_positives, 1);
}

TEST(DamageMapEval, SightingsFromMasks) {
  DamageMapEvalOptions o;
  cv::Mat frame1(80, 100, CV_16UC1, cv::Scalar(0));
  frame1(cv::Rect(40, 30, 10, 10)).setTo(1);  // 100 px inside: whole
  frame1(cv::Rect(1, 30, 10, 10)).setTo(2);   // in column 1: within 2 px of the border
  frame1(cv::Rect(60, 60, 5, 5)).setTo(3);    // 25 px: too few
  frame1(cv::Rect(2, 2, 10, 10)).setTo(4);    // from column/row 2: not within 2 px
  TruthSightings s;
  AddFrameSightings(frame1, o, &s);
  EXPECT_EQ(s[1].Sight(), TruthSight::kWhole);
  EXPECT_EQ(s[2].Sight(), TruthSight::kPartial);
  EXPECT_EQ(s[3].Sight(), TruthSight::kPartial);
  EXPECT_EQ(s[4].Sight(), TruthSight::kWhole);
  EXPECT_EQ(s[3].max_pixels, 25);
  EXPECT_EQ(s.count(5), 0u);

  cv::Mat frame2(80, 100, CV_16UC1, cv::Scalar(0));
  frame2(cv::Rect(20, 20, 10, 10)).setTo(2);
  AddFrameSightings(frame2, o, &s);
  EXPECT_EQ(s[2].frames_whole, 1);
  EXPECT_EQ(s[2].frames_partial, 1);
  EXPECT_EQ(s[2].Sight(), TruthSight::kWhole);
  EXPECT_EQ(s[1].frames_whole, 1);

  EXPECT_THROW(AddFrameSightings(cv::Mat(4, 4, CV_8UC1), o, &s), std::invalid_argument);
}

// A damage beyond the range the damage stage analysed in a frame is not seen whole there.
TEST(DamageMapEval, SightingsStopAtTheAnalysedRange) {
  DamageMapEvalOptions o;
  cv::Mat masks(80, 100, CV_16UC1, cv::Scalar(0));
  masks(cv::Rect(40, 10, 10, 10)).setTo(1);  // far: 10 m
  masks(cv::Rect(40, 50, 10, 10)).setTo(2);  // near: 5 m
  cv::Mat disparity(80, 100, CV_32FC1, cv::Scalar(20));  // bf = 100 px·m: Z = 5 m
  disparity(cv::Rect(0, 0, 100, 40)).setTo(10);         // Z = 10 m
  TruthSightings s;
  AddFrameSightings(masks, o, &s, disparity, 100, 8.0);
  EXPECT_EQ(s[1].Sight(), TruthSight::kPartial);
  EXPECT_EQ(s[2].Sight(), TruthSight::kWhole);
}

TEST(DamageMapEval, BadFeaturesNameTheFile) {
  geojson::FeatureCollection truth, pred;
  truth.features.push_back(Circle(0, 0, 0.25, TruthPothole(1, 0.25)));
  auto expect_error = [&](const geojson::Feature& f, const std::string& text) {
    geojson::FeatureCollection p;
    p.features.push_back(f);
    try {
      ScoreDamageMap(truth, p, kOrigin, Seen({1}, {}), {}, "truth.geojson", "out/damage.geojson");
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().path, "out/damage.geojson");
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  expect_error(Circle(0, 0, 0.25, {{"type", "pothole"}}), "integer id");
  expect_error(Circle(0, 0, 0.25, Predicted(3, "bump")), "pothole, crack or other");
  expect_error(Line(0, 0, 1, 0, Predicted(3, "pothole")), "Polygon");
  expect_error(Circle(0, 0, 0.25, Predicted(3, "crack")), "LineString");
  json bad = Predicted(3, "pothole");
  bad["max_depth_m"] = "deep";
  expect_error(Circle(7, 0, 0.25, bad), "max_depth_m");  // checked although it matches nothing
  json bad_flag = Predicted(3, "pothole");
  bad_flag["floor_visible"] = 1;
  expect_error(Circle(0, 0, 0.25, bad_flag), "floor_visible");

  json no_diameter = TruthPothole(2, 0.3);
  no_diameter.erase("mean_diameter_m");
  truth.features.push_back(Circle(5, 0, 0.3, no_diameter));
  EXPECT_THROW(ScoreDamageMap(truth, pred, kOrigin, {}, {}), InputError);
}

TEST(DamageMapEval, OptionsStateTheRuleBroken) {
  DamageMapEvalOptions o;
  o.min_overlap = 0;
  try {
    o.Check();
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "min_overlap = 0 violates 0 < min_overlap <= 1");
  }
}

TEST(DamageMapEval, EmptyMapHasNoPrecision) {
  geojson::FeatureCollection truth, pred;
  truth.features.push_back(Circle(0, 0, 0.25, TruthPothole(1, 0.25)));
  const DamageMapEvaluation e = ScoreDamageMap(truth, pred, kOrigin, Seen({1}, {}), {});
  EXPECT_EQ(e.potholes.misses, 1);
  EXPECT_DOUBLE_EQ(e.potholes.recall, 0);
  EXPECT_TRUE(std::isnan(e.potholes.precision));
  EXPECT_TRUE(e.ToJson()["potholes"]["counts"]["precision"].is_null());
  EXPECT_FALSE(e.Table().empty());
}


// A crack longer than one view: its mask pixels, placed on the map with the true disparity and
// pose, cover the line over the frames together.
TEST(DamageMapEval, CrackLineSeenOverFrames) {
  const std::vector<cv::Point2d> line = {{0, 0}, {1, 0}};
  std::vector<cv::Point2d> half;
  for (double x = 0; x <= 0.5; x += 0.005) half.emplace_back(x, 0.003);
  EXPECT_NEAR(LineSeenShare(line, half, 0.02, 0.01), 0.52, 0.02);  // 0.5 m seen + the 2 cm tolerance
  EXPECT_EQ(LineSeenShare(line, {}, 0.02, 0.01), 0.0);

  // One pixel of id 7 at the principal point, 4 m away, from a camera 1 m east looking down.
  cv::Mat masks = cv::Mat::zeros(5, 5, CV_16UC1), disparity(5, 5, CV_32FC1, cv::Scalar(0));
  masks.at<uint16_t>(2, 2) = 7;
  masks.at<uint16_t>(0, 0) = 3;  // not asked for
  const double f = 100, b = 0.2;
  disparity.at<float>(2, 2) = static_cast<float>(f * b / 4);
  disparity.at<float>(0, 0) = 5;
  const cv::Matx44d enu_from_camera(1, 0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 4, 0, 0, 0, 1);  // nadir at 4 m
  std::map<int, std::vector<cv::Point2d>> points;
  AddFramePixelsOnMap(masks, disparity, f, 2, 2, b, enu_from_camera, {7}, &points);
  ASSERT_EQ(points.size(), 1u);
  ASSERT_EQ(points[7].size(), 1u);
  EXPECT_NEAR(points[7][0].x, 1.0, 1e-6);
  EXPECT_NEAR(points[7][0].y, 0.0, 1e-6);
}

}  // namespace
}  // namespace rs
