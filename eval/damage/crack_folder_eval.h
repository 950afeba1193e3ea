#pragma once
// Crack detection scored on a folder of real photographs with pixel masks (images/NAME.jpg,
// masks/NAME.jpg, no metric scale): DetectCracks in pixel units (classical or learned, as
// options.detector resolves), tolerance scoring per image and pooled.

#include "eval/damage/crack_score.h"
#include "stages/damage/damage_options.h"

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

struct CrackFolderImage {
  std::string name;
  TolerantPixelScore score;
  int cracks = 0;        ///< crack instances detected
  std::string detector;  ///< the detector used (CrackDetectorName, pixel units)
};

struct CrackFolderEvaluation {
  std::vector<CrackFolderImage> images;  ///< sorted by name
  TolerantPixelScore overall;            ///< pooled pixel counts
  int images_without_crack = 0;          ///< images where nothing was detected
  int images_without_truth = 0;          ///< images whose mask holds no crack pixel
  std::string detector;                  ///< the detector used on every image, else "mixed"
  double wall_s = 0;                     ///< the whole evaluation (reading, detecting, scoring), s
  double detect_s = 0;                   ///< DetectCracks summed over the images (one thread each), s
};

/// Every image of `dir`/images with a mask of the same name in `dir`/masks (crack = mask grey
/// value ≥ 128: the masks may be lossy JPEG). Images are read as colour and searched whole;
/// `max_images` > 0 takes every n-th pair so that at most that many are scored. Throws
/// InputError for a missing folder, an unreadable image or a mask of another size.
/// `debug_dir` (non-empty): writes NAME.png per image: the image, the truth (green) and the
/// detection (magenta) side by side.
CrackFolderEvaluation EvaluateCrackFolder(const std::filesystem::path& dir, const CrackOptions& options,
                                          double tolerance_px, int max_images = 0,
                                          const std::filesystem::path& debug_dir = {});

}  // namespace rs
