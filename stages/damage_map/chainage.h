#pragma once
// Chainage and offset, as road agencies reference defects: distance along the surveyed line
// (the cameras' ground track, in flight order) from its start, and the signed distance across it.

#include <vector>

#include <Eigen/Core>

namespace rs {

class Centreline {
 public:
  /// `track` in flight order (local ENU); points closer than `min_step_m` to the last kept point
  /// are dropped (hovering, a stopped car). Passes of the track within `same_road_m` of each other
  /// (about half a lane) are one road, referenced on its first pass.
  explicit Centreline(const std::vector<Eigen::Vector3d>& track, double min_step_m = 0.1, double same_road_m = 2.0);

  bool valid() const { return points_.size() >= 2; }
  double length_m() const { return cumulative_.empty() ? 0 : cumulative_.back(); }

  struct Station {
    double chainage_m;  ///< along the line from its start (beyond the ends: extrapolated)
    double offset_m;    ///< across it, positive to the right of the direction of travel
  };
  /// The station of a point (horizontal); NaNs when the line is not valid.
  Station StationOf(const Eigen::Vector3d& p) const;

 private:
  std::vector<Eigen::Vector2d> points_;
  std::vector<double> cumulative_;
  double same_road_m_ = 2.0;
};

}  // namespace rs
