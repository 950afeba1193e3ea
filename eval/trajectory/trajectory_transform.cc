#include "eval/trajectory/trajectory_transform.h"

namespace rs {

Trajectory ApplyExtrinsic(const Trajectory& trajectory, const Eigen::Isometry3d& T_frame_new) {
  Trajectory out = trajectory;
  for (StampedPose& p : out.poses) p.T_world_frame = p.T_world_frame * T_frame_new;
  return out;
}

}  // namespace rs
