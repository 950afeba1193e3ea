#include "stages/report/report_stage.h"

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <fstream>

#include "formats/checked_file.h"
#include "formats/geo/georeference_file.h"
#include "stages/report/ortho_pieces.h"
#include "stages/report/report_assets.h"
#include "stages/report/report_data.h"
#include "survey/atomic_file.h"
#include "survey/hash.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr const char* kStage = "report";

// The artifact through which the report reads each stage's folder, in pipeline order.
constexpr std::pair<const char*, const char*> kStageArtifacts[] = {
    {"ingest", "frames"},           {"disparity", "disparity"},   {"damage", "damage"},
    {"slam", "trajectory"},         {"refine", "trajectory_refined"}, {"georeference", "georeference"},
    {"damage_map", "damage_map"},   {"surface", "surface"}};

// Leaflet's files the page loads (the marker images are referenced by leaflet.css).
const std::vector<std::string>& LeafletFiles() {
  static const std::vector<std::string> files = {"leaflet.js",
                                                 "leaflet.css",
                                                 "images/layers.png",
                                                 "images/layers-2x.png",
                                                 "images/marker-icon.png",
                                                 "images/marker-icon-2x.png",
                                                 "images/marker-shadow.png"};
  return files;
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot read");
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void WriteAssets(const fs::path& report) {
  for (const ReportAsset& a : ReportAssets()) {
    fs::create_directories((report / a.name).parent_path());
    WriteFileChecked(report / a.name, std::string_view(reinterpret_cast<const char*>(a.bytes), a.size));
  }
}

void CopyLeaflet(const fs::path& from, const fs::path& report) {
  for (const std::string& f : LeafletFiles()) {
    const fs::path src = from / f;
    if (!fs::exists(src))
      throw InputError(InputLocation::File(src.string()),
                       "Leaflet is missing: install Debian's libjs-leaflet (./setup.sh) or set report.leaflet_dir");
    fs::create_directories((report / "leaflet" / f).parent_path());
    WriteFileChecked(report / "leaflet" / f, ReadBytes(src));
  }
}

// The data as JSON and as a script assigning it (file:// pages may load scripts, not fetch files).
void WriteData(const fs::path& report, const std::string& name, const char* variable, const nlohmann::json& j) {
  const std::string text = j.dump();
  WriteFileChecked(report / "data" / (name + ".json"), text + "\n");
  WriteFileChecked(report / "data" / (name + ".js"), fmt::format("window.{} = {};\n", variable, text));
}

// The best view's thumbnail, scaled down to max_px; its path in the report, or null when absent.
nlohmann::json CopyThumbnail(const fs::path& from, const fs::path& report, int id, int max_px) {
  const fs::path src = from / fmt::format("{}.jpg", id);
  if (!fs::exists(src)) return nullptr;
  const std::string rel = fmt::format("thumbnails/{}.jpg", id);
  fs::create_directories(report / "thumbnails");
  cv::Mat img = cv::imread(src.string(), cv::IMREAD_COLOR);
  if (img.empty()) throw InputError(InputLocation::File(src.string()), "not a readable JPEG");
  if (std::max(img.cols, img.rows) <= max_px) {
    WriteFileChecked(report / rel, ReadBytes(src));
    return rel;
  }
  const double s = static_cast<double>(max_px) / std::max(img.cols, img.rows);
  cv::resize(img, img, cv::Size(), s, s, cv::INTER_AREA);
  std::vector<uchar> bytes;
  cv::imencode(".jpg", img, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
  WriteFileChecked(report / rel, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  return rel;
}

// What each stage's finished run recorded (stage.json): times, frames, warnings, skipped frames.
// These differ between runs of the same inputs, so they go to data/run.js, apart from the products.
nlohmann::json RunRecord(const ReportSources& src) {
  nlohmann::json stages = nlohmann::json::array(), warnings = nlohmann::json::array(),
                 skipped = nlohmann::json::array();
  double total = 0;
  std::string finished;
  for (const auto& [stage, artifact] : kStageArtifacts) {
    const fs::path marker = src.at(stage) / kStageMarker;
    if (!fs::exists(marker)) continue;
    const nlohmann::json m = ReadJsonFile(marker);
    const auto frames = m.value("frames", nlohmann::json::object());
    stages.push_back({{"name", stage},
                      {"wall_s", m.value("wall_s", 0.0)},
                      {"finished_utc", m.value("finished_utc", std::string())},
                      {"frames_computed", frames.value("computed", 0)},
                      {"frames_reused", frames.value("reused", 0)},
                      {"frames_skipped", frames.value("skipped", 0)},
                      {"timings_s", m.value("timings_s", nlohmann::json::object())}});
    total += m.value("wall_s", 0.0);
    finished = std::max(finished, m.value("finished_utc", std::string()));
    for (const auto& w : m.value("warnings", nlohmann::json::array())) warnings.push_back({{"stage", stage}, {"message", w}});
    for (const auto& s : frames.value("skipped_frames", nlohmann::json::array()))
      skipped.push_back({{"stage", stage},
                         {"frame", s.value("frame", 0)},
                         {"reason", s.value("reason", std::string())},
                         {"where", s.value("where", std::string())}});
  }
  return {{"stages", stages}, {"total_s", total}, {"finished_utc", finished}, {"warnings", warnings},
          {"skipped_frames", skipped}};
}

// The map (track, orthophoto pieces, damages with their thumbnails) in the survey CRS about a round
// origin, and the damage counts, into `data`.
void AddMap(const ReportSources& src, const ReportTrack& track, const OrthoPieces* ortho, const fs::path& report,
            const ReportOptions& o, nlohmann::json& data) {
  const GeoreferenceFile geo = ReadGeoreferenceFile(src.at("georeference") / "georeference.json");
  const auto crs = geo.MakeCrs();
  const MapFrame frame = MapFrameAbout(track.positions.front());
  const fs::path geojson = src.at("damage_map") / "damage.geojson";
  ReportDamages damages;
  if (fs::exists(geojson)) damages = DamagesOnMap(geojson, *crs, geo.origin.h_ellipsoid_m, frame);
  for (auto& d : damages.damages)
    d["thumbnail"] =
        CopyThumbnail(src.at("damage_map") / "damage_thumbnails", report, d["id"].get<int>(), o.thumbnail_max_px);
  nlohmann::json ortho_json;
  if (ortho) {
    nlohmann::json pieces = nlohmann::json::array();
    for (const OrthoPiece& p : ortho->pieces)
      pieces.push_back({{"file", p.file}, {"bounds", {frame.Point(p.x_min, p.y_min), frame.Point(p.x_max, p.y_max)}}});
    ortho_json = {{"cell_m", ortho->cell_x}, {"pieces", pieces}};
  }
  data["map"] = {{"origin_crs", {frame.origin.x(), frame.origin.y()}},
                 {"extent", MapExtent(track, ortho, 1.0, frame)},
                 {"ortho", ortho_json},
                 {"trajectory", TrackPoints(track, o.trajectory_max_points, frame)}};
  data["damages"] = std::move(damages.damages);
  if (!damages.counts.is_null()) data["counts"] = damages.counts;
}

int64_t FolderBytes(const fs::path& dir) {
  int64_t bytes = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) bytes += static_cast<int64_t>(e.file_size());
  return bytes;
}

}  // namespace

void ReportOptions::Check() const {}

const OptionTable<ReportOptions>& ReportOptions::Table() {
  using O = ReportOptions;
  static const auto t =
      OptionTable<O>()
          .Add("ortho_max_pixels", &O::ortho_max_pixels,
               "orthophoto pixels with data shown on the map: the finest of ortho.tif's overview levels that fits "
               "(the full-resolution file is linked)",
               "px")
          .Min(10000)
          .Add("ortho_piece_px", &O::ortho_piece_px, "side of the square image pieces the orthophoto is cut into", "px")
          .Min(64)
          .Max(4096)
          .Add("ortho_quality", &O::ortho_quality, "WebP quality of the orthophoto pieces (100: best)")
          .Min(1)
          .Max(100)
          .Add("trajectory_max_points", &O::trajectory_max_points,
               "the trajectory line is drawn through at most this many cameras (evenly spaced)")
          .Min(2)
          .Add("thumbnail_max_px", &O::thumbnail_max_px, "damage thumbnails larger than this are scaled down", "px")
          .Min(32)
          .Add("reference_trajectory", &O::reference_trajectory,
               "CSV `t_ns,lat_deg,lon_deg,h_ellipsoid_m`: the left camera's position at each frame time from an "
               "independent source (a post-processed GNSS solution; the simulator writes its truth), relative to "
               "the survey file; the report charts the cameras' horizontal and vertical difference from it "
               "(empty: no chart)")
          .Add("leaflet_dir", &O::leaflet_dir,
               "folder holding leaflet.js, leaflet.css and images/ (Debian's libjs-leaflet), copied into the report");
  return t;
}

StageInfo ReportStage::Info() {
  StageInfo info;
  info.name = kStage;
  info.version = 1;
  info.doc =
      "One offline HTML page for the people who commission the survey: summary (date, length, frames, CRS, GNSS "
      "quality, time per stage, warnings, skipped frames), a map (orthophoto, trajectory, damage by severity), a "
      "sortable and filterable damage table with thumbnails and every measurement, charts (counts, depths, GNSS "
      "residuals) and links to every product; publishes report/index.html (works from file://, prints to A4).";
  for (const auto& [stage, artifact] : kStageArtifacts) info.inputs.push_back(artifact);
  info.outputs = {"report"};
  info.published = {{"report", "report"}};
  return info;
}

void ReportStage::ValidateInputs(const SurveyFile& survey, const ReportOptions& o, ValidationDepth,
                                 ProblemList& problems) const {
  if (!o.reference_trajectory.empty() && !fs::exists(survey.Resolve(o.reference_trajectory)))
    problems.Error(InputLocation::File(survey.Resolve(o.reference_trajectory).string()),
                   "report.reference_trajectory: no such file");
  // A warning, not an error: every other stage can still run; the report stage fails naming the file.
  for (const std::string& f : LeafletFiles())
    if (!fs::exists(fs::path(o.leaflet_dir) / f)) {
      problems.Warning(InputLocation::File((fs::path(o.leaflet_dir) / f).string()),
                       "Leaflet is missing: the report stage will fail; install Debian's libjs-leaflet (./setup.sh) "
                       "or set report.leaflet_dir");
      return;
    }
}

std::string ReportStage::ExtraKeyOf(const SurveyFile& survey, const ReportOptions& o) const {
  // The page, the copied library and the reference trajectory are part of the output: a new page, a
  // Leaflet upgrade or another reference writes the report again.
  KeyHasher h;
  for (const ReportAsset& a : ReportAssets())
    h.Add(a.name).Add(std::string_view(reinterpret_cast<const char*>(a.bytes), a.size));
  const auto digest = [](const fs::path& p) { return fs::exists(p) ? Sha256OfFile(p) : std::string("missing"); };
  if (!o.reference_trajectory.empty()) h.Add(digest(survey.Resolve(o.reference_trajectory)));
  for (const std::string& f : LeafletFiles()) h.Add(digest(fs::path(o.leaflet_dir) / f));
  return h.Hex();
}

void ReportStage::Run(StageContext& ctx, const ReportOptions& o) const {
  const auto t0 = std::chrono::steady_clock::now();
  ReportSources src;
  for (const auto& [stage, artifact] : kStageArtifacts) src[stage] = ctx.input_dir(artifact);
  const fs::path report = ctx.out_dir() / "report";
  fs::create_directories(report / "data");
  WriteAssets(report);
  CopyLeaflet(o.leaflet_dir, report);

  const nlohmann::json georeference = ReadJsonFile(src.at("georeference") / "georeference.json");
  const std::vector<CameraRow> cameras = ReadCamerasCsv(src.at("georeference") / "cameras.csv");
  const ReportTrack track = TrackOf(cameras);
  const fs::path ortho_tif = src.at("surface") / "surface" / "ortho.tif";
  std::optional<OrthoPieces> ortho;
  if (fs::exists(ortho_tif)) ortho = WriteOrthoPieces(ortho_tif, report, {o.ortho_max_pixels, o.ortho_piece_px, o.ortho_quality});

  nlohmann::json data = {{"format", "roadsurvey-report-v1"},
                         {"title", ctx.survey().name},
                         {"survey", SurveySummary(ctx.survey().name, src, track, georeference)},
                         {"counts", {{"by_type", nlohmann::json::object()}, {"by_severity", nlohmann::json::object()}}},
                         {"map", nullptr},
                         {"damages", nlohmann::json::array()},
                         {"residuals", ResidualsOf(src.at("georeference") / "georeference_residuals.csv", georeference)},
                         {"trajectory_error", nullptr},
                         {"files", ProductLinks(src)}};
  if (georeference.value("georeferenced", false) && !track.positions.empty())
    AddMap(src, track, ortho ? &*ortho : nullptr, report, o, data);
  else
    ctx.Warn("the cameras are not georeferenced: the report has no map");
  if (!o.reference_trajectory.empty())
    data["trajectory_error"] = TrajectoryError(cameras,
                                               ctx.survey().Resolve(o.reference_trajectory), o.trajectory_max_points);
  WriteData(report, "report", "ROADSURVEY_REPORT", data);
  WriteData(report, "run", "ROADSURVEY_RUN", RunRecord(src));

  ctx.Count("damages", static_cast<double>(data["damages"].size()));
  ctx.Count("ortho_pieces", ortho ? static_cast<double>(ortho->pieces.size()) : 0.0);
  if (ortho) ctx.Count("ortho_cell_m", ortho->cell_x);
  const double mb = static_cast<double>(FolderBytes(report)) / 1e6;
  ctx.Count("report_mb", mb);
  ctx.summary().counts["headline"] =
      fmt::format("report/index.html (open in a browser): {} damages, {}, {:.1f} MB", data["damages"].size(),
                  ortho ? fmt::format("orthophoto at {:.0f} mm", ortho->cell_x * 1000) : std::string("no orthophoto"), mb);
  ctx.Time("report", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace rs
