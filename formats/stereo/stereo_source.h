#pragma once
// Stereo frame sources: the folder layouts roadsurvey ingests (plain, KITTI odometry,
// KITTI raw, EuRoC/ASL), each listed as time-stamped left/right image pairs plus the
// calibration found in the layout. Layouts: docs/formats/stereo-sources.md.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "formats/input_error.h"
#include "formats/stereo_calibration.h"

namespace rs {

/// One stereo pair of a source.
struct StereoFrame {
  int64_t t_ns = 0;             ///< capture time, int64 nanoseconds on the source's own time base
  std::filesystem::path left;   ///< left (reference) image
  std::filesystem::path right;  ///< right image
  InputLocation where;          ///< where the frame is declared (timestamps.csv:118), for messages
};

/// The folder layouts a StereoSource can read.
enum class StereoLayout { kPlain, kKittiOdometry, kKittiRaw, kEuroc };

/// "plain", "kitti-odometry", "kitti-raw", "euroc".
std::string ToString(StereoLayout layout);
/// Inverse of ToString; throws InputError (location = option_name) for an unknown name.
StereoLayout ParseStereoLayout(const std::string& name, const std::string& option_name = "layout");

/// A listed stereo sequence. Frames are in file order; OpenStereoSource checks that
/// timestamps strictly increase.
class StereoSource {
 public:
  StereoSource(StereoLayout layout, std::filesystem::path root, std::vector<StereoFrame> frames,
               std::optional<StereoCalibration> calibration, bool timestamps_synthesized, ProblemList warnings)
      : layout_(layout),
        root_(std::move(root)),
        frames_(std::move(frames)),
        calibration_(std::move(calibration)),
        timestamps_synthesized_(timestamps_synthesized),
        warnings_(std::move(warnings)) {}

  StereoLayout layout() const { return layout_; }
  const std::filesystem::path& root() const { return root_; }
  const std::vector<StereoFrame>& frames() const { return frames_; }
  /// The calibration the layout carries (calib.txt, sensor.yaml, calibration.yaml), if any.
  const std::optional<StereoCalibration>& calibration() const { return calibration_; }
  /// True when the layout had no capture times (KITTI odometry without times.txt) and
  /// t_ns was set to frame_index * 100 ms, KITTI's nominal 10 Hz. Reported as a warning.
  bool timestamps_synthesized() const { return timestamps_synthesized_; }
  /// Non-fatal findings of the listing (unpaired EuRoC stamps, unlisted images, ...).
  const ProblemList& warnings() const { return warnings_; }

 private:
  StereoLayout layout_;
  std::filesystem::path root_;
  std::vector<StereoFrame> frames_;
  std::optional<StereoCalibration> calibration_;
  bool timestamps_synthesized_ = false;
  ProblemList warnings_;
};

/// Recognises the layout of folder from the files present; throws InputError naming the
/// folder when none matches.
StereoLayout DetectLayout(const std::filesystem::path& folder);

/// Lists the frames of folder. layout: "auto" or a ToString(StereoLayout) name.
/// problems == nullptr: the first problem throws InputError (ingest). Otherwise every
/// problem is recorded (errors and warnings, with file and line), offending frames are
/// left out and listing goes on (validate). Images are not opened here.
StereoSource OpenStereoSource(const std::filesystem::path& folder, const std::string& layout = "auto",
                              ProblemList* problems = nullptr);

/// Checks everything `roadsurvey validate` checks about a stereo folder, collecting ALL
/// problems: layout files, timestamps (unparsable, duplicate, non-monotonic), left/right
/// counts, every image present and decodable, left/right sizes equal and equal to the
/// calibration's. Returns the number of frames that passed every check.
int ValidateStereoFolder(const std::filesystem::path& folder, const std::string& layout, ProblemList* problems);

/// The image half of ValidateStereoFolder for a source already opened (with `problems`, so its
/// listing problems are recorded once): every image decodable, sizes equal and equal to the
/// calibration's. Returns the number of frames that passed. With `bad_frames_are_skipped` (what a run
/// does with such a frame) each bad frame is a warning saying so, not an error; a missing file is not
/// reported again (listing the source already warned about it).
int ValidateStereoImages(const StereoSource& source, ProblemList* problems, bool bad_frames_are_skipped = false);

}  // namespace rs
