#include "stages/damage_map/damage_map_stage.h"

#include "stages/damage_map/link_cracks.h"

#include <fmt/format.h>

#include <GeographicLib/LocalCartesian.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <set>

#include "formats/checked_file.h"
#include "formats/damage/detections_file.h"
#include "formats/frame_index.h"
#include "formats/rectified_stereo.h"
#include "formats/geo/georeference_file.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/trajectory/tum_trajectory.h"
#include "stages/damage_map/chainage.h"
#include "stages/damage_map/damage_map_outputs.h"
#include "stages/damage_map/footprint_overlap.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr const char* kStage = "damage_map";

// Every selected frame's detections on the map, with the cameras' ground track in flight order.
struct PlacedSurvey {
  std::vector<MapObservation> obs;
  std::vector<Eigen::Vector3d> track;
  std::map<int64_t, fs::path> left_image;
  std::vector<ExaminedView> views;  ///< frames the damage stage examined that have a pose
  RectifiedStereo camera;
  int frames_with_detections = 0, frames_without_pose = 0, detections_unplaced = 0;
};

PlacedSurvey PlaceSurvey(StageContext& ctx, const GeoreferenceFile& geo, const DamageMapOptions& o) {
  const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
  const StereoCalibration calib = ReadCalibrationYaml(ctx.input_dir("calibration") / "calibration.yaml");
  const fs::path traj_path = ctx.input_dir("trajectory_refined") / "trajectory_refined.tum";
  std::map<int64_t, Eigen::Isometry3d> pose_by_t;
  for (const auto& sp : ReadTumTrajectory(traj_path).poses) pose_by_t.emplace(sp.t_ns, sp.T_world_frame);
  const fs::path damage_dir = ctx.input_dir("damage");
  PlacedSurvey s;
  s.camera = RectifiedStereoOf(calib);
  const Eigen::Affine3d slam_from_enu = geo.SlamFromEnu();
  for (const FrameRecord& f : frames) {
    if (!ctx.frame_selection().Contains(f.id.value)) continue;
    s.left_image[f.id.value] = f.left;
    const auto pose = pose_by_t.find(f.t_ns);
    if (pose != pose_by_t.end()) s.track.push_back(geo.ToEnu(pose->second.translation()));
    const fs::path path = StageContext::FrameDirIn(damage_dir, f.id) / "detections.json";
    if (!fs::exists(path)) continue;  // the damage stage skipped the frame (listed in its summary)
    const FrameDetections detections = ReadFrameDetections(path);
    if (pose != pose_by_t.end())
      s.views.push_back(
          {f.id.value, Eigen::Affine3d(pose->second.inverse().matrix()) * slam_from_enu, detections.analysed_range_m});
    if (detections.detections.empty()) continue;
    ++s.frames_with_detections;
    if (pose == pose_by_t.end()) {
      ++s.frames_without_pose;
      s.detections_unplaced += static_cast<int>(detections.detections.size());
      continue;
    }
    const Eigen::Isometry3d T = pose->second;
    auto placed = PlaceDetections(
        detections, [&](const Eigen::Vector3d& p) { return geo.ToEnu(T * p); }, calib.left.width, calib.left.height,
        o.border_px);
    for (auto& p : placed) s.obs.push_back(std::move(p));
  }
  return s;
}

// The examined frames that detected the damage or had its centre in view, and the share that detected it.
void RateDetection(const PlacedSurvey& s, int border_px, MappedDamage& m) {
  const Eigen::Vector3d centre = m.type == "crack" ? PolylineMidpoint(m.geometry_enu) : m.centroid_enu;
  std::set<int64_t> detected, looked;
  for (int i : m.members) detected.insert(s.obs[i].frame);
  looked = detected;
  for (int64_t f : FramesInView(s.views, s.camera, centre, border_px)) looked.insert(f);
  m.views_in_view = static_cast<int>(looked.size());
  m.detection_rate = static_cast<double>(detected.size()) / static_cast<double>(looked.size());
}

struct LeftOut {
  int few_views = 0;   ///< fewer observations than min_observations
  int unrepeated = 0;  ///< detection rate below min_detection_rate
};

// Fuses each group of crack views, links the pieces whose ends face each other across a short
// gap (link_cracks.h) and appends one crack per linked set to `out`.
void AppendLinkedCracks(const std::vector<MapObservation>& obs, const std::vector<std::vector<int>>& groups,
                        const CrackFusionOptions& co, const DamageMapOptions& o, std::vector<MappedDamage>& out) {
  std::vector<MappedDamage> pieces;
  std::vector<std::vector<Eigen::Vector3d>> lines;
  for (const auto& members : groups) {
    pieces.push_back(FuseCrack(obs, members, co));
    lines.push_back(pieces.back().geometry_enu);
  }
  const CrackLinkOptions lo{o.crack_link_gap_m, o.crack_link_angle_deg};
  std::vector<CrackBridge> bridges;
  for (const auto& linked : LinkCrackPieces(lines, lo, o.merge_tolerance_m, &bridges)) {
    if (linked.size() == 1) {
      out.push_back(std::move(pieces[linked.front()]));
      continue;
    }
    std::vector<int> members;
    for (int p : linked) members.insert(members.end(), pieces[p].members.begin(), pieces[p].members.end());
    std::sort(members.begin(), members.end());
    std::vector<std::vector<Eigen::Vector3d>> gaps;
    for (const CrackBridge& b : bridges)
      if (std::binary_search(linked.begin(), linked.end(), b.piece)) gaps.push_back(b.segment);
    out.push_back(FuseCrack(obs, members, co, gaps));
  }
}

// Merges the views of each damage and fuses them; ids follow chainage (then offset).
std::vector<MappedDamage> BuildMap(const PlacedSurvey& s, const Centreline& line, const DamageMapOptions& o,
                                   LeftOut* dropped) {
  std::vector<int> depressions, cracks;
  for (int i = 0; i < static_cast<int>(s.obs.size()); ++i)
    (s.obs[i].detection.type == "crack" ? cracks : depressions).push_back(i);
  const auto groups = [&](const std::vector<int>& idx, double min_overlap, double cell) {
    std::vector<Footprint> f;
    for (int i : idx) f.push_back(FootprintOf(s.obs[i].outline_enu));
    auto g = GroupByOverlap(f, o.merge_tolerance_m, cell, min_overlap);
    for (auto& members : g)
      for (int& m : members) m = idx[m];
    return g;
  };
  std::vector<MappedDamage> out;
  const FusionOptions fo{o.best_views};
  for (const auto& members : groups(depressions, o.min_overlap, o.cell_m))
    out.push_back(FuseDepression(s.obs, members, fo));
  CrackFusionOptions co;
  co.cell_m = o.crack_cell_m;
  co.gap_m = o.merge_tolerance_m;
  AppendLinkedCracks(s.obs, groups(cracks, o.crack_min_overlap, o.crack_cell_m), co, o, out);
  for (MappedDamage& m : out) RateDetection(s, o.border_px, m);
  const auto before = out.size();
  std::erase_if(out, [&](const MappedDamage& m) { return static_cast<int>(m.members.size()) < o.min_observations; });
  dropped->few_views = static_cast<int>(before - out.size());
  const auto seen = out.size();
  std::erase_if(out, [&](const MappedDamage& m) { return m.detection_rate < o.min_detection_rate; });
  dropped->unrepeated = static_cast<int>(seen - out.size());

  for (MappedDamage& m : out) {
    const auto st = line.StationOf(m.centroid_enu);
    m.chainage_m = st.chainage_m;
    m.offset_m = st.offset_m;
    GradeMappedDamage(m, o.severity);
  }
  std::stable_sort(out.begin(), out.end(), [](const MappedDamage& a, const MappedDamage& b) {
    return std::make_pair(a.chainage_m, a.offset_m) < std::make_pair(b.chainage_m, b.offset_m);
  });
  for (size_t i = 0; i < out.size(); ++i) out[i].id = static_cast<int>(i) + 1;
  return out;
}

// Counts by type and severity, for damage_map.json, the manifest and the run's summary line.
nlohmann::json CountsOf(const std::vector<MappedDamage>& damages) {
  nlohmann::json c = nlohmann::json::object();
  for (const char* type : {"pothole", "crack", "other"}) c[type] = {{"total", 0}};
  for (const MappedDamage& m : damages) {
    auto& t = c[m.type];
    t["total"] = t["total"].get<int>() + 1;
    t[m.severity] = t.value(m.severity, 0) + 1;
  }
  return c;
}

std::string Headline(const nlohmann::json& counts) {
  std::string s;
  for (const char* type : {"pothole", "crack", "other"}) {
    const auto& t = counts[type];
    std::string levels;
    for (const char* level : {"high", "medium", "low", "none"})
      if (t.contains(level)) levels += fmt::format("{}{} {}", levels.empty() ? "" : ", ", level, t[level].get<int>());
    s += fmt::format("{}{} {}{}", s.empty() ? "" : "; ", t["total"].get<int>(),
                     type == std::string("other") ? "other" : std::string(type) + "s",
                     levels.empty() ? "" : " (" + levels + ")");
  }
  return s;
}

void PublishEmpty(StageContext& ctx, const std::string& why) {
  WriteFileChecked(ctx.out_dir() / "damage.geojson", "{\"type\":\"FeatureCollection\",\"features\":[]}\n");
  WriteFileChecked(ctx.out_dir() / "damage.csv", "id\n");
  WriteQgisStyles(ctx.out_dir());
  fs::create_directories(ctx.out_dir() / "damage_thumbnails");
  WriteJsonAtomic(ctx.out_dir() / "damage_map.json",
                  {{"format", "roadsurvey-damage-map-v1"}, {"mapped", false}, {"reason", why}});
  ctx.Warn("no damage map: " + why);
}

}  // namespace

void DamageMapOptions::Check() const {
  CheckRule(best_views >= 1, kStage, "best_views", best_views, ">= 1");
  CheckRule(min_detection_rate >= 0 && min_detection_rate <= 1, kStage, "min_detection_rate", min_detection_rate,
            "in [0, 1]");
  CheckRule(min_overlap > 0 && min_overlap <= 1, kStage, "min_overlap", min_overlap, "in (0, 1]");
  CheckRule(crack_min_overlap > 0 && crack_min_overlap <= 1, kStage, "crack_min_overlap", crack_min_overlap,
            "in (0, 1]");
  CheckRule(crack_link_angle_deg >= 0 && crack_link_angle_deg <= 90, kStage, "crack_link_angle_deg",
            crack_link_angle_deg, "in [0, 90]");
  severity.Check();
}

const OptionTable<DamageMapOptions>& DamageMapOptions::Table() {
  using O = DamageMapOptions;
  static const auto t =
      OptionTable<O>()
          .Add("merge_tolerance_m", &O::merge_tolerance_m,
               "buffer around each view's outline when testing overlap: the relative pose error between views of "
               "one damage; also the largest gap closed between a crack's pieces",
               "m")
          .Min(0)
          .Add("min_overlap", &O::min_overlap,
               "potholes and other depressions: two views show one damage when this share of the smaller "
               "footprint lies in the other's buffer")
          .Above(0)
          .Add("crack_min_overlap", &O::crack_min_overlap, "the same for cracks (thin outlines seen in pieces)")
          .Above(0)
          .Add("cell_m", &O::cell_m, "raster cell of the overlap test", "m")
          .Above(0)
          .Add("border_px", &O::border_px,
               "an outline within this many pixels of the image border is cut by it (area and volume are lower "
               "bounds; such a view is used only when no view holds the whole outline)",
               "px")
          .Min(0)
          .Add("best_views", &O::best_views, "views of the best rank the measurements are fused from")
          .Min(1)
          .Add("min_observations", &O::min_observations,
               "damages seen by fewer views are left out of the map (counted in damage_map.json)")
          .Min(1)
          .Add("min_detection_rate", &O::min_detection_rate,
               "a damage stays on the map when at least this share of the examined views that had its centre "
               "in view (or detected it) detected it: real damage is seen by every view of it, spurious "
               "detections are not repeated (0 keeps all)")
          .Min(0)
          .Add("crack_cell_m", &O::crack_cell_m, "raster cell of a crack's merged outline and centreline", "m")
          .Above(0)
          .Add("crack_link_gap_m", &O::crack_link_gap_m,
               "crack pieces whose ends face each other across a gap up to this long are one crack (a crack's "
               "contrast dips along it, and where it dips in every view the map holds pieces); 0 links none",
               "m")
          .Min(0)
          .Add("crack_link_angle_deg", &O::crack_link_angle_deg,
               "ends face each other when the gap between them lies within this angle of both ends' directions", "deg")
          .Min(0)
          .Add("thumbnails", &O::thumbnails, "write damage_thumbnails/<id>.jpg (a crop of the best view)")
          .Include("severity", &O::severity, SeverityOptions::Table());
  return t;
}

StageInfo DamageMapStage::Info() {
  StageInfo info;
  info.name = kStage;
  info.version = 2;  // 2: crack pieces facing each other across a short gap are one crack
  info.doc =
      "Every pothole and crack once, on the map: per-frame detections placed with the georeferenced cameras, views "
      "of one damage merged by overlap on the road plane, measurements fused from the best views and graded, "
      "chainage and offset along the surveyed line; publishes damage.geojson (WGS84), damage.csv (survey CRS), "
      "QGIS styles and thumbnails.";
  info.inputs = {"frames", "calibration", "damage", "trajectory_refined", "georeference"};
  info.outputs = {"damage_map"};
  info.published = {{"damage.geojson", "damage.geojson"},   {"damage.csv", "damage.csv"},
                    {"damage.qml", "damage.qml"},           {"damage_cracks.qml", "damage_cracks.qml"},
                    {"damage_map.json", "damage_map.json"}, {"damage_thumbnails", "damage_thumbnails"}};
  info.per_frame = true;  // its result depends on the frame selection
  return info;
}

void DamageMapStage::Run(StageContext& ctx, const DamageMapOptions& o) const {
  const auto t0 = std::chrono::steady_clock::now();
  const GeoreferenceFile geo = ReadGeoreferenceFile(ctx.input_dir("georeference") / "georeference.json");
  if (!geo.georeferenced) {
    PublishEmpty(ctx, "the cameras are not georeferenced: " + geo.reason);
    return;
  }
  const PlacedSurvey placed = PlaceSurvey(ctx, geo, o);
  const Centreline line(placed.track);
  LeftOut dropped;
  const std::vector<MappedDamage> damages = BuildMap(placed, line, o, &dropped);
  const GeographicLib::LocalCartesian enu(geo.origin.lat_deg, geo.origin.lon_deg, geo.origin.h_ellipsoid_m);
  const auto crs = geo.MakeCrs();
  WriteDamageGeoJson(ctx.out_dir() / "damage.geojson", damages, placed.obs, enu);
  WriteDamageCsv(ctx.out_dir() / "damage.csv", damages, placed.obs, enu, *crs);
  WriteQgisStyles(ctx.out_dir());
  fs::create_directories(ctx.out_dir() / "damage_thumbnails");
  if (o.thumbnails)
    for (const MappedDamage& m : damages) {
      const MapObservation& best = placed.obs[m.best];
      WriteThumbnail(ctx.out_dir() / "damage_thumbnails" / fmt::format("{}.jpg", m.id),
                     placed.left_image.at(best.frame), best);
    }
  const nlohmann::json counts = CountsOf(damages);
  const double sigma_h = std::hypot(geo.sigma_enu_m.x(), geo.sigma_enu_m.y());
  WriteJsonAtomic(ctx.out_dir() / "damage_map.json",
                  {{"format", "roadsurvey-damage-map-v1"},
                   {"mapped", true},
                   {"crs", {{"spec", geo.crs_spec}, {"epsg", crs->epsg()}, {"heights", ToString(crs->heights())}}},
                   {"damages", damages.size()},
                   {"counts", counts},
                   {"observations", placed.obs.size()},
                   {"frames_with_detections", placed.frames_with_detections},
                   {"frames_without_pose", placed.frames_without_pose},
                   {"detections_unplaced", placed.detections_unplaced},
                   {"left_out_below_min_observations", dropped.few_views},
                   {"left_out_below_min_detection_rate", dropped.unrepeated},
                   {"examined_frames_with_pose", placed.views.size()},
                   {"centreline_length_m", line.length_m()},
                   {"position_sigma_m",
                    {{"horizontal", sigma_h},
                     {"vertical", geo.sigma_enu_m.z()},
                     {"definition",
                      "robust sigma of the GNSS fit's residuals (georeference.json): the cameras' "
                      "absolute placement; views of one damage share most of it"}}},
                   {"chainage",
                    "metres along the cameras' ground track from the first frame; offset positive to "
                    "the right of the direction of travel"}});
  ctx.summary().frames_total = static_cast<int64_t>(placed.left_image.size());
  ctx.summary().frames_computed = ctx.summary().frames_total;
  ctx.Count("damages", static_cast<double>(damages.size()));
  for (const char* type : {"pothole", "crack", "other"})
    ctx.Count(std::string(type) + "s", counts[type]["total"].get<double>());
  ctx.Count("observations", static_cast<double>(placed.obs.size()));
  ctx.summary().counts["headline"] = Headline(counts);
  if (placed.frames_without_pose > 0)
    ctx.Warn(
        fmt::format("{} frame(s) with detections have no trajectory pose: their {} detection(s) are not on the map",
                    placed.frames_without_pose, placed.detections_unplaced));
  ctx.Time("damage_map", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace rs
