#pragma once
// One frame's detection placed on the map: its outline on the road surface carried from the left
// camera into the survey's local ENU frame with that frame's georeferenced pose.

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "formats/damage/detections_file.h"

namespace rs {

/// One detection of one frame, on the map (local ENU, metres).
struct MapObservation {
  int64_t frame = 0;
  DamageDetection detection;                ///< the frame's own measurement
  std::vector<Eigen::Vector3d> outline_enu;  ///< outline on the road surface
  bool complete = true;  ///< the outline stays clear of the image border: the whole damage is in view
};

/// Maps a left-camera point of one frame to local ENU.
using CameraToEnu = std::function<Eigen::Vector3d(const Eigen::Vector3d& p_cam)>;

/// Places every detection of a frame with at least three outline points. `complete` is false when
/// an outline pixel lies within `border_px` of the image border (width × height).
std::vector<MapObservation> PlaceDetections(const FrameDetections& frame, const CameraToEnu& to_enu, int width,
                                            int height, int border_px);

/// Horizontal area centroid of a ring (x east, y north); the vertex mean for a degenerate ring.
Eigen::Vector2d RingCentroid(const std::vector<Eigen::Vector3d>& ring);

}  // namespace rs
