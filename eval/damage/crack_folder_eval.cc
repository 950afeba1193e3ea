#include "eval/damage/crack_folder_eval.h"

#include "formats/image_file.h"
#include "formats/input_error.h"
#include "stages/damage/cracks/cracks.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>

namespace rs {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> PairedNames(const fs::path& dir) {
  const fs::path images = dir / "images", masks = dir / "masks";
  if (!fs::is_directory(images) || !fs::is_directory(masks))
    throw InputError(InputLocation::File(dir.string()), "expected the folders images/ and masks/");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(images))
    if (e.is_regular_file() && fs::exists(masks / e.path().filename())) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  if (names.empty()) throw InputError(InputLocation::File(dir.string()), "no image with a mask of the same name");
  return names;
}

cv::Mat ReadOrThrow(const fs::path& path, int flags) {
  cv::Mat m = cv::imread(path.string(), flags);
  if (m.empty()) throw InputError(InputLocation::File(path.string()), "cannot read the image");
  return m;
}

// The image, the truth over it (green) and the detection over it (magenta), side by side.
void WriteDebug(const fs::path& path, const cv::Mat& image, const cv::Mat& mask, const CrackDetection& d) {
  cv::Mat truth = image.clone(), detected = image.clone();
  truth.setTo(cv::Scalar(0, 255, 0), mask >= 128);
  detected.setTo(cv::Scalar(255, 0, 255), d.labels != 0);
  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{image, truth, detected}, row);
  if (row.cols > 2400) cv::resize(row, row, {}, 2400.0 / row.cols, 2400.0 / row.cols, cv::INTER_AREA);
  fs::create_directories(path.parent_path());
  WriteImageFile(path, row);
}

}  // namespace

CrackFolderEvaluation EvaluateCrackFolder(const fs::path& dir, const CrackOptions& options, double tolerance_px,
                                          int max_images, const fs::path& debug_dir) {
  std::vector<std::string> names = PairedNames(dir);
  if (max_images > 0 && int(names.size()) > max_images) {
    const size_t step = (names.size() + max_images - 1) / max_images;
    std::vector<std::string> kept;
    for (size_t i = 0; i < names.size(); i += step) kept.push_back(names[i]);
    names.swap(kept);
  }
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  CrackFolderEvaluation out;
  out.images.resize(names.size());
  std::atomic<int64_t> detect_ns{0};
  tbb::parallel_for(size_t(0), names.size(), [&](size_t i) {
    const fs::path image_path = dir / "images" / names[i], mask_path = dir / "masks" / names[i];
    const cv::Mat image = ReadOrThrow(image_path, cv::IMREAD_COLOR);
    const cv::Mat mask = ReadOrThrow(mask_path, cv::IMREAD_GRAYSCALE);
    if (mask.size() != image.size())
      throw InputError(InputLocation::File(mask_path.string()), "mask size differs from the image's");
    const Clock::time_point t = Clock::now();
    const CrackDetection d = DetectCracks(image, cv::Mat(), cv::Mat(), cv::Mat(), options);
    detect_ns += std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t).count();
    CrackFolderImage& r = out.images[i];
    r.name = names[i];
    r.cracks = int(d.instances.size());
    r.detector = CrackDetectorName(d.detector, false);
    r.score = ScoreCrackPixels(d.labels != 0, mask >= 128, tolerance_px);
    if (!debug_dir.empty()) WriteDebug(debug_dir / (fs::path(names[i]).stem().string() + ".png"), image, mask, d);
  });
  for (const CrackFolderImage& r : out.images) {
    out.detector = out.detector.empty() || out.detector == r.detector ? r.detector : "mixed";
    out.overall += r.score;
    out.images_without_crack += r.cracks == 0;
    out.images_without_truth += r.score.truth == 0;
  }
  out.detect_s = detect_ns * 1e-9;
  out.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

}  // namespace rs
