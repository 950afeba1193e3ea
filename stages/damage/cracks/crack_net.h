#pragma once
// The learned crack detector's model: a compact U-Net (ONNX, trained by
// model/train_crack_net.py on real pavement photographs) that maps a grey image to a crack
// probability per pixel, run through OpenCV's dnn module. Kept apart from the classical code so
// that only this library links opencv_dnn.

#include <opencv2/core.hpp>

#include <filesystem>
#include <stdexcept>
#include <string>

namespace rs {

/// A model file that cannot be used: missing, unreadable, not a network OpenCV can import, or
/// with unusable metadata. The message names the file.
class CrackModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What the model file and the JSON beside it (same stem, .json, written by the training
/// script) say about it.
struct CrackModelInfo {
  std::filesystem::path path;  ///< the .onnx file
  std::string sha256;          ///< of the .onnx file's bytes
  double threshold = 0.5;      ///< probability chosen on the training hold-out ("threshold")
  int stride_px = 8;           ///< input sides must be multiples of this ("stride_px")
  /// A tile's standard deviation is taken as at least this many grey levels ("min_std_grey":
  /// the flattest training photograph's, rounded down; 1 where the JSON has none).
  double min_std_grey = 1;
  /// The component rules that go with the model ("components": chosen on the training hold-out
  /// like the threshold); 0 where the JSON has none: the options' min_length_px, min_elongation.
  int min_length_px = 0;
  double min_elongation = 0;
};

/// The committed model: the source tree's stages/damage/cracks/model/crack_net.onnx when it
/// exists, else the installed copy (<datadir>/roadsurvey/crack_net.onnx), else the former
/// (missing).
std::filesystem::path DefaultCrackModelPath();

/// `path` when non-empty, else DefaultCrackModelPath().
std::filesystem::path ResolveCrackModelPath(const std::string& path);

/// Loads (once per path and process; thread-safe) and describes the model at `path`. Throws
/// CrackModelError naming the file when it is missing, unreadable or not importable, or when
/// its JSON exists but lacks a valid threshold.
const CrackModelInfo& LoadCrackModel(const std::filesystem::path& path);

/// Crack probability (CV_32F in [0, 1], the image's size) of `grey` (CV_8U) by the model at
/// `path`. Each tile (the whole image up to 384 px a side, else 320 px tiles overlapping by 64)
/// is normalised to mean 0, standard deviation 1 (a standard deviation taken as at least the
/// model's min_std_grey), as in training, and
/// padded by reflection to the model's stride. Safe to call from several threads (one network
/// instance per thread).
cv::Mat CrackProbability(const cv::Mat& grey, const std::filesystem::path& path);

}  // namespace rs
