#include "stages/surface/surface_stage.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "formats/frame_index.h"
#include "formats/geo/georeference_file.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/trajectory/tum_trajectory.h"
#include "stages/surface/hole_fill.h"
#include "stages/surface/surface_frames.h"
#include "stages/surface/surface_products.h"
#include "stages/surface/tile_store.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr const char* kStage = "surface";
constexpr int kFootprintStride = 8;    // px: pixels sampled for a frame's footprint
constexpr double kFootprintCell = 0.25;  // m: the footprint's resolution before it becomes tiles

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The selected frames that have a pose and a disparity, in flight order.
std::vector<SurfaceFrame> ListFrames(StageContext& ctx, const GeoreferenceFile& geo, const OutputCrs& crs,
                                     int* without_pose, int* without_mask) {
  const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
  std::map<int64_t, Eigen::Isometry3d> pose_by_t;
  for (const auto& sp : ReadTumTrajectory(ctx.input_dir("trajectory_refined") / "trajectory_refined.tum").poses)
    pose_by_t.emplace(sp.t_ns, sp.T_world_frame);
  std::vector<SurfaceFrame> out;
  for (const FrameRecord& f : frames) {
    if (!ctx.frame_selection().Contains(f.id.value)) continue;
    const fs::path disp_dir = StageContext::FrameDirIn(ctx.input_dir("disparity"), f.id);
    if (!fs::exists(disp_dir / "disparity.png")) continue;  // skipped by the disparity stage (listed there)
    const auto pose = pose_by_t.find(f.t_ns);
    if (pose == pose_by_t.end()) {
      ++*without_pose;
      continue;
    }
    SurfaceFrame s;
    s.id = f.id.value;
    s.disparity = disp_dir / "disparity.png";
    if (fs::exists(disp_dir / "disparity_sharp.png")) s.disparity_sharp = disp_dir / "disparity_sharp.png";
    s.road_model = disp_dir / "road_model.json";
    s.left = f.left;
    const fs::path road = StageContext::FrameDirIn(ctx.input_dir("damage"), f.id) / "road.png";
    if (!fs::exists(road)) {  // the damage stage skipped the frame: no road mask, obstacles unknown
      ++*without_mask;
      continue;
    }
    s.road_mask = road;
    s.damage_labels = road.parent_path() / "labels.png";
    s.crs_from_camera = CrsFromCamera(pose->second, geo, crs);
    out.push_back(std::move(s));
  }
  return out;
}

// The grid over every frame's footprint, and for each tile the last frame (sequence number) whose
// footprint reaches it or its neighbours.
struct GridPlan {
  SurfaceGrid grid;
  std::vector<int64_t> last_use;
  double median_pixel_m = 0;
};

GridPlan PlanGrid(const std::vector<SurfaceFrame>& frames, const RectifiedStereo& camera, const FrameLoadOptions& lo,
                  const SurfaceOptions& o, StageContext& ctx) {
  std::vector<std::set<std::pair<int64_t, int64_t>>> footprints(frames.size());
  std::vector<double> pixel_m;
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  ctx.progress().Start("surface footprints", static_cast<int64_t>(frames.size()));
  for (size_t i = 0; i < frames.size(); ++i) {
    const FrameView v = LoadFrameView(frames[i], camera, lo);
    for (const Eigen::Vector2d& p : FrameFootprint(v, kFootprintStride)) {
      x0 = std::min(x0, p.x()), y0 = std::min(y0, p.y()), x1 = std::max(x1, p.x()), y1 = std::max(y1, p.y());
      footprints[i].insert({static_cast<int64_t>(std::floor(p.x() / kFootprintCell)),
                            static_cast<int64_t>(std::floor(p.y() / kFootprintCell))});
    }
    if (const double g = MedianPixelFootprintM(v, kFootprintStride); g > 0) pixel_m.push_back(g);
    ctx.progress().Advance();
  }
  ctx.progress().Finish();
  if (pixel_m.empty() || !(x1 > x0)) throw std::runtime_error("surface: no frame has a valid road pixel to fuse");
  GridPlan plan;
  std::nth_element(pixel_m.begin(), pixel_m.begin() + pixel_m.size() / 2, pixel_m.end());
  plan.median_pixel_m = pixel_m[pixel_m.size() / 2];
  SurfaceGrid& g = plan.grid;
  // A cell holds at least one pixel of a typical view: never finer than the median pixel (mm steps).
  g.cell = std::max(o.cell_m, std::ceil(plan.median_pixel_m * 1000.0) / 1000.0);
  g.tile = o.tile_cells;
  const double margin = kFootprintCell;
  g.x_min = std::floor((x0 - margin) / g.cell) * g.cell;
  g.y_max = std::ceil((y1 + margin) / g.cell) * g.cell;
  g.cols = static_cast<int>(std::ceil((x1 + margin - g.x_min) / g.cell));
  g.rows = static_cast<int>(std::ceil((g.y_max - (y0 - margin)) / g.cell));
  plan.last_use.assign(g.tile_count(), -1);
  for (size_t i = 0; i < frames.size(); ++i)
    for (const auto& [qx, qy] : footprints[i]) {
      // The footprint cell's corners, in tiles, and their neighbours.
      for (double fx : {0.0, 1.0})
        for (double fy : {0.0, 1.0}) {
          const int64_t tc = g.ColOf((qx + fx) * kFootprintCell) / g.tile;
          const int64_t tr = g.RowOf((qy + fy) * kFootprintCell) / g.tile;
          for (int64_t dr = -1; dr <= 1; ++dr)
            for (int64_t dc = -1; dc <= 1; ++dc) {
              const int64_t c = tc + dc, r = tr + dr;
              if (c < 0 || r < 0 || c >= g.tiles_across() || r >= g.tiles_down()) continue;
              int64_t& last = plan.last_use[r * g.tiles_across() + c];
              last = std::max(last, static_cast<int64_t>(i));
            }
        }
    }
  return plan;
}

RasterCrs RasterCrsOf(const OutputCrs& crs) {
  RasterCrs r;
  const std::string& epsg = crs.epsg();  // "EPSG:32633", "EPSG:27700+5773", "" (local ENU)
  if (!epsg.empty()) {
    const auto plus = epsg.find('+');
    r.epsg = std::stoi(epsg.substr(5, plus == std::string::npos ? std::string::npos : plus - 5));
    if (plus != std::string::npos) r.vertical_epsg = std::stoi(epsg.substr(plus + 1));
  }
  r.citation = crs.is_local_enu() ? crs.wkt() : epsg;
  r.heights = crs.heights() == HeightReference::kGeoidEgm96 ? "height above the EGM96 geoid (EPSG:5773)"
                                                            : "height above the WGS84 ellipsoid";
  if (crs.is_local_enu()) r.heights = "up of the local tangent plane";
  return r;
}

void PublishNothing(StageContext& ctx, const std::string& why) {
  fs::create_directories(ctx.out_dir() / "surface");
  WriteJsonAtomic(ctx.out_dir() / "surface" / "surface.json",
                  {{"format", "roadsurvey-surface-v1"}, {"surface", false}, {"reason", why}});
  ctx.Warn("no surface products: " + why);
}

}  // namespace

void SurfaceOptions::Check() const {
  CheckRule(cell_m > 0, kStage, "cell_m", cell_m, "> 0");
  CheckRule(tile_cells >= 16 && tile_cells % 16 == 0, kStage, "tile_cells", tile_cells, "a multiple of 16");
  CheckRule(keep_views >= 1 && keep_views <= 255, kStage, "keep_views", keep_views, "in [1, 255]");
  CheckRule(damage_margin_px >= 0, kStage, "damage_margin_px", damage_margin_px, ">= 0");
  CheckRule(min_views >= 1, kStage, "min_views", min_views, ">= 1");
  CheckRule(resident_frames >= 1, kStage, "resident_frames", resident_frames, ">= 1");
  CheckRule(mesh_max_height_error_m > 0, kStage, "mesh_max_height_error_m", mesh_max_height_error_m, "> 0");
}

const OptionTable<SurfaceOptions>& SurfaceOptions::Table() {
  using O = SurfaceOptions;
  static const auto t =
      OptionTable<O>()
          .Add("cell_m", &O::cell_m,
               "grid cell of the DSM, orthophoto and mesh; the frames' median pixel footprint when that is larger",
               "m")
          .Above(0)
          .Add("tile_cells", &O::tile_cells,
               "side of the square tiles fused, written and meshed one at a time (and of the GeoTIFF tiles)", "cells")
          .Min(16)
          .Add("keep_views", &O::keep_views,
               "observations kept per cell (those with the smallest height σ) for its robust fusion")
          .Min(1)
          .Add("min_views", &O::min_views,
               "cells seen by fewer views are left empty: a height no second view confirms may be a mismatch")
          .Min(1)
          .Add("damage_margin_px", &O::damage_margin_px,
               "within this many pixels of a detected damage the disparity stage's sharp image is fused (walls "
               "in place) instead of its smooth one (half the disparity stage's default smooth window)",
               "px")
          .Min(0)
          .Add("fill_holes_m", &O::fill_holes_m,
               "empty regions inside a tile at most this wide are filled from their rim (view count 0, σ raised by "
               "the rim's height spread); 0 leaves every hole",
               "m")
          .Min(0)
          .Add("max_range_m", &O::max_range_m, "pixels deeper than this are not fused (0: no limit)", "m")
          .Min(0)
          .Add("disparity_sigma_px", &O::disparity_sigma_px,
               "disparity σ behind each pixel's depth σ (0: each frame's road-fit residual RMS)", "px")
          .Min(0)
          .Add("min_disparity_sigma_px", &O::min_disparity_sigma_px, "floor of the per-frame disparity σ", "px")
          .Above(0)
          .Add("resident_frames", &O::resident_frames,
               "a tile no frame has touched for this many frames is spilled to disk until a later pass needs it "
               "(bounds memory on long surveys)")
          .Min(1)
          .Add("mesh", &O::mesh, "write mesh.ply and mesh.obj")
          .Add("mesh_max_height_error_m", &O::mesh_max_height_error_m,
               "mesh decimation keeps every grid point within this vertical distance of the mesh", "m")
          .Above(0);
  return t;
}

StageInfo SurfaceStage::Info() {
  StageInfo info;
  info.name = kStage;
  info.version = 1;
  info.doc =
      "Road surface products in the survey's CRS: every frame's road disparity (obstacles left out) placed with the "
      "georeferenced cameras and fused tile by tile into a height grid (robust, uncertainty-weighted); publishes "
      "surface/dsm.tif, dsm_sigma.tif, dsm_count.tif, ortho.tif (GeoTIFF with overviews) and a decimated mesh "
      "(mesh.ply, mesh.obj, mesh.json).";
  info.inputs = {"frames", "calibration", "disparity", "damage", "trajectory_refined", "georeference"};
  info.outputs = {"surface"};
  info.published = {{"surface", "surface"}};
  info.per_frame = true;  // its result depends on the frame selection
  return info;
}

void SurfaceStage::Run(StageContext& ctx, const SurfaceOptions& o) const {
  const auto t0 = Clock::now();
  // A run killed part-way leaves its rasters, mesh temporaries and spilled tiles: start clean.
  fs::remove_all(ctx.out_dir() / "surface");
  fs::remove_all(ctx.out_dir() / "spill");
  const GeoreferenceFile geo = ReadGeoreferenceFile(ctx.input_dir("georeference") / "georeference.json");
  if (!geo.georeferenced) return PublishNothing(ctx, "the cameras are not georeferenced: " + geo.reason);
  const auto crs = geo.MakeCrs();
  const RasterCrs raster_crs = RasterCrsOf(*crs);
  if (!crs->is_local_enu() && crs->epsg().rfind("EPSG:4", 0) == 0 && raster_crs.epsg < 5000)
    return PublishNothing(ctx, "the survey CRS " + crs->epsg() + " is geographic: a DSM needs a projected CRS");
  const RectifiedStereo camera =
      RectifiedStereoOf(ReadCalibrationYaml(ctx.input_dir("calibration") / "calibration.yaml"));
  int without_pose = 0, without_mask = 0;
  const std::vector<SurfaceFrame> frames = ListFrames(ctx, geo, *crs, &without_pose, &without_mask);
  if (frames.empty()) return PublishNothing(ctx, "no frame has both a disparity and a pose");

  FrameLoadOptions lo;
  lo.disparity_sigma_px = o.disparity_sigma_px;
  lo.min_disparity_sigma_px = o.min_disparity_sigma_px;
  lo.max_range_m = o.max_range_m;
  lo.damage_margin_px = o.damage_margin_px;
  lo.colour = false;
  const GridPlan plan = PlanGrid(frames, camera, lo, o, ctx);
  const SurfaceGrid& g = plan.grid;
  ctx.Time("footprints", Since(t0));

  const fs::path dir = ctx.out_dir() / "surface";
  fs::create_directories(dir);
  SurfaceRasters rasters(dir, g, raster_crs);
  TileStore store(g.tile * g.tile, o.keep_views, plan.last_use, ctx.out_dir() / "spill");
  const double fill_cells = o.fill_holes_m / g.cell;
  const auto emit = [&](int tile, const TileAccumulator& acc) {
    FusedTile t = acc.Fuse(g.tile, o.min_views);
    if (fill_cells > 0) FillSmallHoles(&t, fill_cells);
    rasters.WriteTile(tile, t);
  };
  lo.colour = true;
  int64_t observations = 0;
  const auto t1 = Clock::now();
  ctx.progress().Start("surface", static_cast<int64_t>(frames.size()));
  for (size_t i = 0; i < frames.size(); ++i) {
    const FrameView v = LoadFrameView(frames[i], camera, lo);
    int cached_tile = -1;
    TileAccumulator* acc = nullptr;
    for (const CellSample& s : FrameCellObservations(v, g)) {
      const int64_t col = s.cell % g.cols, row = s.cell / g.cols;
      const int tile = g.TileOf(col, row);
      if (tile != cached_tile) acc = &store.Touch(tile, static_cast<int64_t>(i)), cached_tile = tile;
      acc->Add(static_cast<int>((row % g.tile) * g.tile + col % g.tile), s.obs);
      ++observations;
    }
    store.Release(static_cast<int64_t>(i), o.resident_frames, emit);
    ctx.progress().Advance();
  }
  store.Finish(emit);
  ctx.progress().Finish();
  rasters.Finish();
  const double fuse_s = Since(t1);
  ctx.Time("fuse", fuse_s);

  const SurfaceTotals& tot = rasters.totals();
  nlohmann::json mesh_json = nullptr;
  if (o.mesh) {
    const auto t2 = Clock::now();
    // Offset: whole metres near the grid's south-west corner, so float32 vertices keep 0.1 mm.
    const Eigen::Vector3d offset(std::floor(g.x_min), std::floor(g.y_max - g.rows * g.cell),
                                 std::floor(frames.empty() ? 0 : frames[0].crs_from_camera(2, 3) - 20));
    const MeshSummary m = WriteSurfaceMesh(dir, g, tot.tiles_written, offset, o.mesh_max_height_error_m);
    mesh_json = {{"format", "roadsurvey-surface-mesh-v1"},
                 {"files", {"mesh.ply", "mesh.obj"}},
                 {"crs", {{"epsg", crs->epsg()}, {"wkt", crs->wkt()}, {"heights", raster_crs.heights}}},
                 {"offset", {m.offset.x(), m.offset.y(), m.offset.z()}},
                 {"coordinates", "vertex = CRS coordinate - offset (x east/easting, y north/northing, z height), m"},
                 {"grid_vertices", m.grid_vertices},
                 {"grid_faces", m.grid_faces},
                 {"vertices", m.vertices},
                 {"faces", m.faces},
                 {"max_height_error_m", o.mesh_max_height_error_m},
                 {"measured_max_height_error_m", m.max_height_error_m}};
    WriteJsonAtomic(dir / "mesh.json", mesh_json);
    ctx.Time("mesh", Since(t2));
    ctx.Count("mesh_faces", static_cast<double>(m.faces));
  }
  const double mean_sigma = tot.cells_filled > 0 ? tot.sigma_sum_m / static_cast<double>(tot.cells_filled) : 0;
  WriteJsonAtomic(
      dir / "surface.json",
      {{"format", "roadsurvey-surface-v1"},
       {"surface", true},
       {"crs", {{"spec", geo.crs_spec}, {"epsg", crs->epsg()}, {"heights", raster_crs.heights}}},
       {"grid",
        {{"x_min", g.x_min}, {"y_max", g.y_max}, {"cell_m", g.cell}, {"cols", g.cols}, {"rows", g.rows},
         {"tile_cells", g.tile}, {"median_pixel_footprint_m", plan.median_pixel_m}}},
       {"files", {{"dsm", "dsm.tif"}, {"sigma", "dsm_sigma.tif"}, {"count", "dsm_count.tif"}, {"ortho", "ortho.tif"}}},
       {"nodata", kDsmNodata},
       {"frames_fused", frames.size()},
       {"frames_without_pose", without_pose},
       {"frames_without_road_mask", without_mask},
       {"observations", observations},
       {"cells_filled", tot.cells_filled},
       {"cells_interpolated", tot.cells_interpolated},
       {"area_m2", static_cast<double>(tot.cells_filled) * g.cell * g.cell},
       {"mean_sigma_m", mean_sigma},
       {"tiles", tot.tiles},
       {"memory", {{"peak_tile_bytes", store.peak_resident_bytes()}, {"spills", store.spills()},
                   {"reloads", store.reloads()}}},
       {"mesh", mesh_json}});
  ctx.summary().frames_total = static_cast<int64_t>(frames.size());
  ctx.summary().frames_computed = ctx.summary().frames_total;
  ctx.Count("cells", static_cast<double>(tot.cells_filled));
  ctx.Count("area_m2", static_cast<double>(tot.cells_filled) * g.cell * g.cell);
  // Times go to the manifest only: the published files stay byte-identical between runs.
  ctx.Time("fuse_per_frame", fuse_s / static_cast<double>(frames.size()));
  ctx.summary().counts["headline"] =
      fmt::format("{:.1f} m² at {:.0f} mm cells, mean σ {:.1f} mm", static_cast<double>(tot.cells_filled) * g.cell * g.cell,
                  g.cell * 1000, mean_sigma * 1000);
  if (without_pose > 0) ctx.Warn(fmt::format("{} frame(s) have no trajectory pose: not in the surface", without_pose));
  if (without_mask > 0)
    ctx.Warn(fmt::format("{} frame(s) have no road mask (skipped by the damage stage): not in the surface",
                         without_mask));
  ctx.Time("surface", Since(t0));
}

}  // namespace rs
