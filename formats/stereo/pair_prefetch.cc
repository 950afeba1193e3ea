#include "formats/stereo/pair_prefetch.h"

#include <stdexcept>
#include <string>

#include "formats/stereo/image_io.h"

namespace rs {

StereoPairPrefetcher::StereoPairPrefetcher(std::vector<StereoPairFiles> pairs, int ahead)
    : pairs_(std::move(pairs)), ahead_(static_cast<size_t>(ahead)) {
  if (ahead < 1) throw std::invalid_argument("StereoPairPrefetcher: ahead " + std::to_string(ahead) + " < 1");
  Refill();
}

StereoPairPrefetcher::~StereoPairPrefetcher() {
  for (auto& f : decoding_)
    if (f.valid()) f.wait();  // the threads read pairs_
}

void StereoPairPrefetcher::Refill() {
  while (decoding_.size() < ahead_ && started_ < pairs_.size()) {
    const StereoPairFiles* files = &pairs_[started_++];
    decoding_.push_back(std::async(std::launch::async, [files] {
      cv::Mat left = LoadGray8(files->left);
      return std::make_pair(std::move(left), LoadGray8(files->right));
    }));
  }
}

std::pair<cv::Mat, cv::Mat> StereoPairPrefetcher::Next() {
  if (decoding_.empty()) throw std::out_of_range("StereoPairPrefetcher::Next: every pair was returned");
  std::future<std::pair<cv::Mat, cv::Mat>> next = std::move(decoding_.front());
  decoding_.pop_front();
  Refill();           // the pair after the last in flight starts before this one is waited for
  return next.get();  // rethrows the decoding's InputError
}

}  // namespace rs
