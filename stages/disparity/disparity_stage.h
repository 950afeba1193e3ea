#pragma once
// Stage "disparity": dense disparity of every rectified pair by GPT-SGM (road
// model + perspective transformation + our SGM), with plain SGM as fallback.
// Docs: docs/stages/disparity.md.

#include "stages/disparity/disparity.h"
#include "survey/stage.h"

namespace rs {

/// The algorithm's parameters (DisparityParams, registered field by field) plus what to write.
struct DisparityStageOptions {
  DisparityParams params;
  bool temporal_prior = true;     ///< seed each frame's road fit with the previous frame's model
  bool write_transformed = true;  ///< transformed disparity (float TIFF), the damage stage's input
  /// disparity_sharp.png (KITTI 16-bit) where the smooth refinement window ran: the refine_window
  /// pass alone (DisparityResult::disparity_sharp), on which the damage stage sums volumes
  bool write_sharp = true;
  bool write_preview = false;      ///< colour preview PNG per frame
  bool write_point_cloud = false;  ///< metric point cloud PLY per frame (left camera frame)
  bool skip_bad_frames = true;     ///< skip and count frames whose images cannot be read

  void Check() const;
  static const OptionTable<DisparityStageOptions>& Table();
};

class DisparityStage : public TypedStage<DisparityStage, DisparityStageOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const DisparityStageOptions& options) const;
};

}  // namespace rs
