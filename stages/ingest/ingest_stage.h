#pragma once
// Stage "ingest": lists the stereo frames, loads and checks the calibration,
// rectifies raw pairs, checks every image, reads the flight log and gives each
// frame a time-aligned GNSS/attitude prior. Docs: docs/stages/ingest.md.

#include "survey/stage.h"

namespace rs {

struct IngestOptions {
  bool check_images = true;           ///< decode every image (finds corrupt frames before hours of work)
  bool skip_bad_frames = true;        ///< skip and count unreadable frames instead of failing the stage
  double rectify_alpha = 0.0;         ///< stereoRectify free scaling: 0 keeps valid pixels only, 1 keeps all
  bool estimate_clock_offset = true;  ///< estimate camera-log offset from the log's camera events
  double max_log_gap_s = 2.0;         ///< fixes further apart than this leave frames between them without a prior
  double max_speed_m_s = 60.0;        ///< consecutive fixes implying more than this are reported as jumps
  double min_in_span_fraction = 0.5;  ///< fail when fewer frames than this fall inside the log's span

  void Check() const;
  static const OptionTable<IngestOptions>& Table();
};

class IngestStage : public TypedStage<IngestStage, IngestOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const IngestOptions& options) const;
  void ValidateInputs(const SurveyFile& survey, const IngestOptions& options, ValidationDepth depth,
                      ProblemList& problems) const;
};

}  // namespace rs
