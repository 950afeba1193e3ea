#include "stages/disparity/sgm.h"

#include <algorithm>
#include <cstring>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <tbb/task_arena.h>

namespace rs {
namespace {

// Random texture, smoothed, right view shifted by a disparity that varies with the row.
void MakePair(int W, int H, int seed, cv::Mat* left, cv::Mat* right) {
  cv::Mat noise(H, W + 64, CV_8U);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.2);
  *left = noise(cv::Rect(0, 0, W, H)).clone();
  *right = cv::Mat(H, W, CV_8U);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const int d = 3 + v * 7 / H + (u > W / 2 ? 2 : 0);
      right->at<uint8_t>(v, u) = noise.at<uint8_t>(v, std::min(u + d, W + 63));
    }
  cv::Mat n(H, W, CV_8U);
  rng.fill(n, cv::RNG::UNIFORM, 0, 6);
  *right += n;
}

void ExpectIdentical(const SgmOutput& a, const SgmOutput& b) {
  ASSERT_EQ(a.disparity.size(), b.disparity.size());
  int diff = 0, valid = 0;
  for (int v = 0; v < a.disparity.rows; ++v)
    for (int u = 0; u < a.disparity.cols; ++u) {
      const float x = a.disparity.at<float>(v, u), y = b.disparity.at<float>(v, u);
      if (std::memcmp(&x, &y, sizeof(float)) != 0 || a.valid.at<uint8_t>(v, u) != b.valid.at<uint8_t>(v, u)) ++diff;
      valid += a.valid.at<uint8_t>(v, u) != 0;
    }
  EXPECT_EQ(diff, 0);
  EXPECT_GT(valid, a.disparity.total() / 4);  // a non-trivial comparison
}

TEST(Sgm, MatchesReferenceAtAwkwardSizes) {
  struct Case {
    int W, H, min_d, num_d, paths, cw, ch, ad;
    SubpixelMode sub;
  };
  const Case cases[] = {
      {37, 23, 0, 13, 8, 9, 7, 0, SubpixelMode::kEquiangular},
      {41, 19, 2, 17, 4, 5, 5, 1, SubpixelMode::kParabola},
      {33, 29, -3, 15, 8, 7, 5, 2, SubpixelMode::kNone},
      {50, 31, 1, 33, 8, 9, 7, 1, SubpixelMode::kParabola},
  };
  for (const Case& c : cases) {
    cv::Mat l, r;
    MakePair(c.W, c.H, c.W, &l, &r);
    SgmParams p;
    p.min_disparity = c.min_d;
    p.num_disparities = c.num_d;
    p.num_paths = c.paths;
    p.census_width = c.cw;
    p.census_height = c.ch;
    p.ad_weight = c.ad;
    p.subpixel = c.sub;
    SCOPED_TRACE(testing::Message() << c.W << "x" << c.H << " D=" << c.num_d);
    ExpectIdentical(ComputeSgm(l, r, p), ComputeSgmReference(l, r, p));
  }
}

TEST(Sgm, MatchesReference631x479WithRowOffset) {
  cv::Mat l, r;
  MakePair(631, 479, 5, &l, &r);
  SgmParams p;
  p.num_disparities = 7;  // odd count, small range followed by the per-row offset
  p.min_disparity = -1;
  p.row_offset.resize(479);
  for (int v = 0; v < 479; ++v) p.row_offset[v] = 1 + v * 7 / 479;
  ExpectIdentical(ComputeSgm(l, r, p), ComputeSgmReference(l, r, p));
}

// 4 paths over several column blocks (two per thread, at least Dp wide): the fused upward pass +
// winner-takes-all and the right-view winners merged across block borders must still match the
// reference. Both layouts of the 4-path passes: packed (three paths' sums and the cost in one
// uint16; the stage defaults P1/P2 = 20/240 fill exactly 16 bits) and unpacked (P2 = 1900, or an
// AD term making costs wider than 6 bits), with the keyed argmin on and off.
TEST(Sgm, MatchesReferenceFourPathsAcrossColumnBlocks) {
  struct Case {
    int W, H, min_d, num_d, lr;
    bool offsets;
    int p1 = 10, p2 = 120, ad = 0;
  };
  // Narrow last blocks (a 320-wide block for D = 300), ranges of 1..10 vectors.
  const Case cases[] = {{700, 37, -2, 40, 1, true},           {531, 21, 3, 33, 0, false},
                        {769, 17, 0, 112, 2, false},          {700, 9, 0, 300, 1, false},
                        {643, 23, 0, 32, 2, false, 20, 240},     // stage defaults: packed, 16 bits used
                        {531, 19, 1, 40, 1, true, 10, 1900},     // unpacked, keyed argmin off
                        {389, 27, -1, 17, 1, false, 8, 96, 5}};  // AD term: costs up to 162, unpacked
  for (const Case& c : cases) {
    cv::Mat l, r;
    MakePair(c.W, c.H, c.W + 1, &l, &r);
    SgmParams p;
    p.num_paths = 4;
    p.min_disparity = c.min_d;
    p.num_disparities = c.num_d;
    p.lr_max_diff = c.lr;
    p.p1 = c.p1;
    p.p2 = c.p2;
    p.ad_weight = c.ad;
    if (c.offsets) {
      p.row_offset.resize(c.H);
      for (int v = 0; v < c.H; ++v) p.row_offset[v] = (v * 5) / c.H - 1;
    }
    SCOPED_TRACE(testing::Message() << c.W << "x" << c.H << " D=" << c.num_d);
    ExpectIdentical(ComputeSgm(l, r, p), ComputeSgmReference(l, r, p));
  }
}

// The column blocks follow the thread count; the output must not (bit-identical for 1..5 threads).
TEST(Sgm, IdenticalForAnyThreadCount) {
  cv::Mat l, r;
  MakePair(700, 37, 11, &l, &r);
  SgmParams p;
  p.num_paths = 4;
  p.num_disparities = 40;
  SgmOutput first;
  for (int threads = 1; threads <= 5; ++threads) {
    SCOPED_TRACE(testing::Message() << threads << " threads");
    tbb::task_arena arena(threads);
    SgmOutput out;
    arena.execute([&] { out = ComputeSgm(l, r, p); });
    if (threads == 1) {
      ExpectIdentical(out, ComputeSgmReference(l, r, p));
      first = out;
      continue;
    }
    ExpectIdentical(out, first);
  }
}

// Census codes against the definition written out (bit = I(q) < I(p), first compared pixel in
// the most significant used bit, borders replicated), at widths around the 64-pixel vector.
TEST(Sgm, CensusMatchesDefinition) {
  const int sizes[][2] = {{3, 3}, {5, 5}, {9, 7}, {7, 5}, {13, 5}};
  for (const int W : {1, 63, 64, 65, 131}) {
    cv::Mat img(11, W, CV_8U);
    cv::RNG rng(W);
    rng.fill(img, cv::RNG::UNIFORM, 0, 256);
    for (const auto& wh : sizes) {
      const std::vector<uint64_t> codes = CensusTransform(img, wh[0], wh[1]);
      int wrong = 0;
      for (int v = 0; v < img.rows; ++v)
        for (int u = 0; u < W; ++u) {
          uint64_t want = 0;
          for (int dy = -wh[1] / 2; dy <= wh[1] / 2; ++dy)
            for (int dx = -wh[0] / 2; dx <= wh[0] / 2; ++dx) {
              if (dx == 0 && dy == 0) continue;
              const int y = std::clamp(v + dy, 0, img.rows - 1), x = std::clamp(u + dx, 0, W - 1);
              want = (want << 1) | (img.at<uint8_t>(y, x) < img.at<uint8_t>(v, u) ? 1u : 0u);
            }
          wrong += codes[static_cast<size_t>(v) * W + u] != want;
        }
      EXPECT_EQ(wrong, 0) << W << " wide, window " << wh[0] << "x" << wh[1];
    }
  }
}

TEST(Sgm, Nominal) {
  cv::Mat l, r;
  MakePair(160, 90, 3, &l, &r);
  SgmParams p;
  p.num_disparities = 16;
  const SgmOutput o = ComputeSgm(l, r, p);
  int good = 0, valid = 0;
  for (int v = 0; v < 90; ++v)
    for (int u = 12; u < 160; ++u) {
      if (!o.valid.at<uint8_t>(v, u)) continue;
      ++valid;
      const int d = 3 + v * 7 / 90 + (u > 80 ? 2 : 0);
      good += std::abs(o.disparity.at<float>(v, u) - d) < 1.0f;
    }
  EXPECT_GT(valid, 0.8 * 148 * 90);
  EXPECT_GT(good, 0.95 * valid);
}

TEST(Sgm, BadParams) {
  SgmParams p;
  p.p2 = 5;
  p.p1 = 8;
  try {
    p.Check(10);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("p2 = 5 violates p2 > p1 (p1 = 8)"), std::string::npos);
  }
  p = SgmParams{};
  p.census_width = 4;
  EXPECT_THROW(p.Check(10), std::invalid_argument);
  p = SgmParams{};
  p.row_offset = {1, 2};
  EXPECT_THROW(p.Check(10), std::invalid_argument);
  p = SgmParams{};
  p.num_paths = 5;
  EXPECT_THROW(p.Check(10), std::invalid_argument);
  cv::Mat a(10, 10, CV_8U, cv::Scalar(0)), b(10, 11, CV_8U, cv::Scalar(0));
  EXPECT_THROW(ComputeSgm(a, b, SgmParams{}), std::invalid_argument);
}

}  // namespace
}  // namespace rs
