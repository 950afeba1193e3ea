#pragma once
// Internal to the SGM core (sgm*.cc): the bit-sliced census transform by rows (CensusPlan), as
// ComputeSgm runs it per pipeline token, and over a whole image (CensusInto, behind the public
// CensusTransform).

#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs::sgm_detail {

// Census transform of one image, by rows (sgm_census.cc): Prepare pads the
// image and lists the window's neighbour offsets, Rows(v0, v1, codes) writes rows [v0, v1) of the
// W x H codes. Pass 1 runs it on each token's rows just before their cost, so the codes are
// consumed while in cache and the census needs no parallel loops of its own.
struct CensusPlan {
  const cv::Mat* padded = nullptr;  // 64 extra columns on the right: a full vector can be read at every u < W
  std::vector<ptrdiff_t> offsets;   // neighbour address - centre address, in comparison order
  int W = 0, n = 0, rw = 0, rh = 0;
  void Prepare(const cv::Mat& gray8, int window_width, int window_height, cv::Mat* storage);
  void Rows(int v0, int v1, uint64_t* codes) const;
};

// Census codes of the whole image into codes (W*H, by rows), rows in parallel.
void CensusInto(const cv::Mat& gray8, int window_width, int window_height, uint64_t* codes);

}  // namespace rs::sgm_detail
