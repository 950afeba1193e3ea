#pragma once
// Stereo pairs decoded ahead of their use: a survey's frames are read in order, and decoding a pair
// (PNG inflate, bit-depth conversion) costs as much as a frame's feature extraction, so it runs on
// worker threads while the caller works on earlier frames. Results and errors come back in order.

#include <cstddef>
#include <deque>
#include <filesystem>
#include <future>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs {

/// The left and right image files of one frame.
struct StereoPairFiles {
  std::filesystem::path left, right;
};

/// Decodes pairs[i] to 8-bit grey (LoadGray8) up to `ahead` pairs ahead of Next(). Usage:
///   StereoPairPrefetcher p(files, 2);
///   for (size_t i = 0; i < files.size(); ++i) { try { auto [l, r] = p.Next(); ... } catch (InputError&) {...} }
class StereoPairPrefetcher {
 public:
  /// ahead >= 1: pairs decoding at once (each on its own thread); memory holds that many pairs more.
  StereoPairPrefetcher(std::vector<StereoPairFiles> pairs, int ahead);
  ~StereoPairPrefetcher();
  StereoPairPrefetcher(const StereoPairPrefetcher&) = delete;
  StereoPairPrefetcher& operator=(const StereoPairPrefetcher&) = delete;

  /// The next pair's images (left, right), in the order given. Throws the InputError its decoding
  /// raised (missing, truncated or undecodable file), after which Next() goes on with the pair after it;
  /// std::out_of_range when every pair has been returned.
  std::pair<cv::Mat, cv::Mat> Next();

 private:
  void Refill();

  std::vector<StereoPairFiles> pairs_;
  size_t ahead_;
  size_t started_ = 0;  // pairs whose decoding has started
  std::deque<std::future<std::pair<cv::Mat, cv::Mat>>> decoding_;
};

}  // namespace rs
