#pragma once
// frame_priors.csv: each frame's GNSS position and attitude prior, interpolated
// from the flight log at the frame's capture time (ingest writes it; SLAM and
// georeferencing read it). Frames outside the log or inside a gap get a status,
// never an extrapolated value.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "formats/altitude_reference.h"
#include "formats/frame_index.h"

namespace rs {

enum class PriorStatus {
  kOk,           ///< interpolated between two fixes closer than the gap limit
  kOutsideSpan,  ///< before the first or after the last fix: not extrapolated
  kInGap,        ///< between fixes further apart than the gap limit
  kNoLog,        ///< the survey has no flight log
};
const char* ToString(PriorStatus s);

struct FramePrior {
  FrameId id;
  int64_t t_ns = 0;      ///< frame capture time (camera clock)
  int64_t t_log_ns = 0;  ///< the same instant on the log's clock (t_ns - clock offset)
  PriorStatus status = PriorStatus::kNoLog;
  double lat_deg = kNaN, lon_deg = kNaN, alt_m = kNaN;
  AltitudeReference alt_ref = AltitudeReference::kUnknown;
  double h_acc_m = kNaN;  ///< interpolated horizontal accuracy, where the log gives one
  bool has_attitude = false;
  double qw = 1, qx = 0, qy = 0, qz = 0;  ///< body (FRD) -> NED
};

void WriteFramePriors(std::ostream& out, const std::vector<FramePrior>& priors);
void WriteFramePriors(const std::filesystem::path& path, const std::vector<FramePrior>& priors);
std::vector<FramePrior> ReadFramePriors(std::istream& in, const std::string& path_for_errors);
std::vector<FramePrior> ReadFramePriors(const std::filesystem::path& path);

}  // namespace rs
