#pragma once
// Stage "damage_map": every pothole and crack once, on the map. Places each frame's detections
// with its georeferenced pose, merges the views of one physical damage (overlap on the road
// plane), fuses its measurements from the best views, grades it, references it by chainage and
// offset, and publishes damage.geojson, damage.csv, QGIS styles and thumbnails.
// Docs: docs/stages/damage_map.md.

#include "stages/damage_map/fuse_crack.h"
#include "stages/damage_map/fuse_depression.h"
#include "stages/damage_map/view_coverage.h"
#include "survey/stage.h"

namespace rs {

struct DamageMapOptions {
  double merge_tolerance_m = 0.05;   ///< pose error tolerated between views of one damage
  double min_overlap = 0.3;          ///< depressions: share of the smaller footprint that must overlap
  double crack_min_overlap = 0.1;    ///< cracks: the same, for thin outlines seen in pieces
  double cell_m = 0.01;              ///< raster cell of the overlap test
  int border_px = 2;                 ///< an outline this close to the image border is cut by it
  int best_views = 3;                ///< views of the best rank fused
  int min_observations = 1;          ///< damages seen by fewer views are left out (counted)
  double min_detection_rate = 0.5;   ///< share of the views with it in view that must detect it
  double crack_cell_m = 0.005;       ///< raster cell of the merged crack outline
  double crack_link_gap_m = 0.25;    ///< crack pieces facing each other across this gap are one crack
  double crack_link_angle_deg = 30;  ///< largest angle between the gap and the pieces' end directions
  bool thumbnails = true;            ///< write damage_thumbnails/<id>.jpg
  SeverityOptions severity;

  void Check() const;
  static const OptionTable<DamageMapOptions>& Table();
};

class DamageMapStage : public TypedStage<DamageMapStage, DamageMapOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const DamageMapOptions& options) const;
};

}  // namespace rs
