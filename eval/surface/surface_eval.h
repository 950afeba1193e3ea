#pragma once
// The surface stage's products of a simulated survey against the simulator's true road surface
// (truth/road_surface.ply): DSM height errors over the road (absolute, and with the cameras'
// local placement error removed: the trajectory's and georeference's errors are measured on their own), the DSM's
// planimetric offset (the horizontal shift that best aligns its relief with the truth's), holes
// inside the imaged road, and the mesh's surface. `roadsurvey eval surface`.

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace rs {

struct HeightErrors {
  int64_t cells = 0;
  double rmse_m = 0, mean_m = 0, median_abs_m = 0, p95_abs_m = 0, max_abs_m = 0;
  double within_5mm = 0;  ///< share of cells with |error| ≤ 5 mm
  nlohmann::json ToJson() const;
};

struct SurfaceEvaluation {
  double cell_m = 0;
  std::string epsg;
  // Height errors over the truth's carriageway (kerb faces and the 2 cells beside them left out).
  HeightErrors absolute;           ///< DSM − truth as published
  /// Truth moved by the placement error of the cameras around each cell first (Gaussian weights
  /// over horizontal distance, σ 1.5 m): the surface's own error, the trajectory's set apart.
  HeightErrors relative;
  Eigen::Vector3d placement_offset_m = Eigen::Vector3d::Zero();  ///< cameras' mean error (ours − truth), CRS
  int placement_cameras = 0;
  double mean_sigma_m = 0;         ///< mean stated σ (dsm_sigma.tif) over the carriageway
  double within_2_sigma = 0;       ///< share of the carriageway's cells whose relative error is within 2σ
  HeightErrors all_cells;          ///< like `relative`, over every fused cell (verges and kerbs included)
  Eigen::Vector2d planimetric_offset_m = Eigen::Vector2d::Zero();  ///< best-aligning shift of the DSM (ours − truth)
  double planimetric_error_m = 0;           ///< |planimetric_offset_m|
  double planimetric_relative_m = 0;        ///< |planimetric offset − cameras' horizontal placement error|
  int64_t road_cells = 0;                   ///< truth road cells inside the imaged area
  double filled_fraction = 0;               ///< of those, the share the DSM fills
  double largest_hole_m = 0;                ///< widest hole inside the imaged road (2 × its largest inscribed radius)
  int holes_over_5cm = 0;
  std::vector<Eigen::Vector3d> holes;       ///< each hole over 5 cm: CRS x, y of its centre and its width
  HeightErrors mesh;                        ///< the mesh's surface at the cells (relative, like `relative`)
  int64_t mesh_vertices = 0;

  std::string Table() const;
  nlohmann::json ToJson() const;
};

/// Reads <output>/surface/{dsm.tif, mesh.ply, mesh.json}, <output>/georeference.json and cameras.csv,
/// truth/road_surface.ply, truth/georeference.json and truth/trajectory.tum. Throws InputError
/// naming a missing or malformed file.
/// With `error_image`, also writes DSM − truth (cameras' error removed) as a colour PNG: ±20 mm
/// through the turbo map, cells without a DSM height or truth black.
SurfaceEvaluation EvaluateSurface(const std::filesystem::path& survey_dir, const std::filesystem::path& output_dir,
                                  const std::filesystem::path& error_image = {});

/// A binary little-endian PLY triangle mesh (float x, y, z first; faces as uchar-count int lists).
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;
};
/// Throws InputError naming the file on anything else.
TriangleMesh ReadPlyMesh(const std::filesystem::path& path);

}  // namespace rs
