#include "stages/slam/place_recognition.h"

#include <gtest/gtest.h>

#include <array>
#include <random>
#include <set>
#include <vector>

#include <tbb/global_control.h>

#include "stages/slam/stereo_features.h"

namespace rs {
namespace {

// 6000 descriptors around 40 random centres, 0-30 of their 256 bits flipped.
std::vector<std::array<uint8_t, 32>> ClusteredDescriptors() {
  std::mt19937 rng(7);
  std::vector<std::array<uint8_t, 32>> centres(40), out;
  for (auto& c : centres)
    for (auto& b : c) b = static_cast<uint8_t>(rng());
  for (int i = 0; i < 6000; ++i) {
    std::array<uint8_t, 32> d = centres[rng() % centres.size()];
    const int flips = static_cast<int>(rng() % 31);
    for (int f = 0; f < flips; ++f) {
      const unsigned bit = rng() % 256;
      d[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    }
    out.push_back(d);
  }
  return out;
}

// The k-means assignment runs on TBB threads: one thread and all of them must give the same tree.
TEST(Vocabulary, SameWordsOnOneThreadAndMany) {
  const auto descs = ClusteredDescriptors();
  std::vector<const uint8_t*> ptrs;
  for (const auto& d : descs) ptrs.push_back(d.data());
  const Vocabulary many = Vocabulary::Build(ptrs, 8, 3, 1);
  Vocabulary one = [&] {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    return Vocabulary::Build(ptrs, 8, 3, 1);
  }();
  ASSERT_EQ(many.words(), one.words());
  EXPECT_GT(many.words(), 40);
  for (const uint8_t* d : ptrs) ASSERT_EQ(many.Word(d), one.Word(d));
}

// Leaves are k-majority clusters: descriptors of one generating centre, flipped in few bits, mostly
// share a word.
TEST(Vocabulary, NearDescriptorsShareWords) {
  const auto descs = ClusteredDescriptors();
  std::vector<const uint8_t*> ptrs;
  for (const auto& d : descs) ptrs.push_back(d.data());
  const Vocabulary v = Vocabulary::Build(ptrs, 8, 2, 1);  // 64 words at most for 40 clusters
  int same = 0, pairs = 0;
  for (size_t i = 0; i + 1 < descs.size(); ++i)
    for (size_t j = i + 1; j < std::min(descs.size(), i + 50); ++j)
      if (DescriptorDistance(ptrs[i], ptrs[j]) <= 20) {
        ++pairs;
        same += v.Word(ptrs[i]) == v.Word(ptrs[j]);
      }
  ASSERT_GT(pairs, 100);
  EXPECT_GT(static_cast<double>(same) / pairs, 0.8) << same << " of " << pairs;
  // ... and the 40 clusters are told apart (a degenerate tree puts everything in a few words).
  std::set<int> used;
  for (const uint8_t* d : ptrs) used.insert(v.Word(d));
  EXPECT_GE(used.size(), 30u);
}

}  // namespace
}  // namespace rs
