#include "formats/stereo/pair_prefetch.h"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "formats/input_error.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

// Seven pairs, each image filled with its own grey level; pair 3's right image is truncated.
std::vector<StereoPairFiles> WritePairs(const fs::path& d) {
  fs::create_directories(d);
  std::vector<StereoPairFiles> files;
  for (int i = 0; i < 7; ++i) {
    StereoPairFiles f{d / ("l" + std::to_string(i) + ".png"), d / ("r" + std::to_string(i) + ".png")};
    EXPECT_TRUE(cv::imwrite(f.left.string(), cv::Mat(4, 6, CV_8U, cv::Scalar(10 * i))));
    EXPECT_TRUE(cv::imwrite(f.right.string(), cv::Mat(4, 6, CV_8U, cv::Scalar(10 * i + 1))));
    files.push_back(f);
  }
  std::ofstream(files[3].right, std::ios::binary | std::ios::trunc) << "\x89PNG";
  return files;
}

TEST(StereoPairPrefetcher, PairsInOrderAndErrorsAtTheirPair) {
  const fs::path d = fs::temp_directory_path() / "rs_pair_prefetch_test";
  const std::vector<StereoPairFiles> files = WritePairs(d);
  for (int ahead : {1, 3, 10}) {
    StereoPairPrefetcher p(files, ahead);
    for (int i = 0; i < 7; ++i) {
      if (i == 3) {
        try {
          p.Next();
          ADD_FAILURE() << "pair 3 (truncated right image) decoded, ahead " << ahead;
        } catch (const InputError& e) {
          EXPECT_EQ(e.where().path, files[3].right.string()) << e.what();
        }
        continue;
      }
      const auto [l, r] = p.Next();
      ASSERT_EQ(l.type(), CV_8UC1);
      EXPECT_EQ(l.at<uchar>(0, 0), 10 * i) << "pair " << i << ", ahead " << ahead;
      EXPECT_EQ(r.at<uchar>(3, 5), 10 * i + 1) << "pair " << i << ", ahead " << ahead;
    }
    EXPECT_THROW(p.Next(), std::out_of_range);
  }
  EXPECT_THROW(StereoPairPrefetcher(files, 0), std::invalid_argument);
  // Destroyed with pairs still decoding: waits for them, nothing dangles.
  { StereoPairPrefetcher p(files, 5); }
  fs::remove_all(d);
}

}  // namespace
}  // namespace rs
