#pragma once
// Appearance-based place recognition without a downloaded vocabulary: a hierarchical k-majority
// vocabulary tree built from the survey's own ORB descriptors, tf-idf bag-of-words vectors per
// keyframe and the L1 similarity score of DBoW2 (Galvez-Lopez & Tardos 2012).

#include <array>
#include <cstdint>
#include <map>
#include <vector>

namespace rs {

/// Vocabulary tree over 256-bit binary descriptors.
class Vocabulary {
 public:
  /// Clusters `descriptors` (32 bytes each) into a tree of `branching` children per node, `depth`
  /// levels (k-means++ seeding with `seed`, k-majority updates). Deterministic.
  static Vocabulary Build(const std::vector<const uint8_t*>& descriptors, int branching, int depth, unsigned seed);
  /// Word (leaf) of a descriptor, descending by least Hamming distance.
  int Word(const uint8_t* descriptor) const;
  int words() const { return words_; }

 private:
  struct Node {
    std::array<uint8_t, 32> center{};
    std::vector<int> children;
    int word = -1;
  };
  void Split(int node, std::vector<const uint8_t*> descs, int branching, int depth, unsigned seed);
  std::vector<Node> nodes_;
  int words_ = 0;
};

/// Sparse L1-normalised tf-idf vector: word -> weight.
using BowVector = std::map<int, double>;

/// DBoW2 L1 score in [0, 1]: 1 - 0.5 * |a - b|_1 for L1-normalised vectors.
double BowScore(const BowVector& a, const BowVector& b);

/// Bag-of-words vectors of a set of images given their words, with idf from the same set.
std::vector<BowVector> BowVectors(const std::vector<std::vector<int>>& words_per_image, int vocabulary_words);

}  // namespace rs
