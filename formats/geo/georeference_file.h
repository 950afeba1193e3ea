#pragma once
// georeference.json as the georeference stage writes it (format "roadsurvey-georeference-v1"):
// the transform from the SLAM world to the local ENU frame, that frame's WGS84 origin, the output
// CRS and the fit's residual sigmas. Stages that place things on the map read it through here.

#include <filesystem>
#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "formats/geo/output_crs.h"

namespace rs {

struct GeoreferenceFile {
  bool georeferenced = false;
  std::string reason;   ///< why not, when georeferenced is false
  Geodetic origin;      ///< tangent point of the local ENU frame (WGS84, ellipsoidal)
  double scale = 1;     ///< p_enu = scale * R * p_slam + t
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  std::string crs_spec;           ///< survey crs: "utm", "enu", "EPSG:<code>"
  HeightReference heights = HeightReference::kEllipsoid;
  Geodetic crs_origin;            ///< origin of "enu" (else the same as origin)
  Eigen::Vector3d sigma_enu_m = Eigen::Vector3d::Zero();  ///< robust GNSS residual sigma per axis

  /// A SLAM-world point in the local ENU frame.
  Eigen::Vector3d ToEnu(const Eigen::Vector3d& p_slam) const { return scale * (R * p_slam) + t; }
  /// The inverse similarity: local ENU -> SLAM world.
  Eigen::Affine3d SlamFromEnu() const {
    Eigen::Affine3d a = Eigen::Affine3d::Identity();
    a.linear() = R.transpose() / scale;
    a.translation() = -R.transpose() * t / scale;
    return a;
  }
  /// The output CRS this file names (PROJ objects: build once, reuse).
  std::unique_ptr<OutputCrs> MakeCrs() const;
};

/// Throws InputError naming the file and the member on a malformed or foreign file.
GeoreferenceFile ReadGeoreferenceFile(const std::filesystem::path& path);

}  // namespace rs
