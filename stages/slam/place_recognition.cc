#include "stages/slam/place_recognition.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "stages/slam/stereo_features.h"

namespace rs {
namespace {

// Byte v spread over the eight bytes of a word, bit j of v in byte j: adding such words counts eight bits
// at once (up to 255 additions before a byte could overflow).
constexpr std::array<uint64_t, 256> kBitsToBytes = [] {
  std::array<uint64_t, 256> t{};
  for (int v = 0; v < 256; ++v)
    for (int j = 0; j < 8; ++j) t[v] |= static_cast<uint64_t>((v >> j) & 1) << (8 * j);
  return t;
}();

// ones[c][b] += bit b of every descriptor assigned to c; count[c] += their number.
void CountBits(const std::vector<const uint8_t*>& descs, const std::vector<int>& assign,
               std::vector<std::array<int, 256>>* ones, std::vector<int>* count) {
  const size_t k = ones->size();
  std::vector<std::array<uint64_t, 32>> packed(k);
  std::vector<int> in_packed(k, 0);
  for (auto& p : packed) p.fill(0);
  auto spill = [&](size_t c) {
    for (int byte = 0; byte < 32; ++byte)
      for (int j = 0; j < 8; ++j) (*ones)[c][8 * byte + j] += static_cast<int>((packed[c][byte] >> (8 * j)) & 0xff);
    packed[c].fill(0);
    in_packed[c] = 0;
  };
  for (size_t i = 0; i < descs.size(); ++i) {
    const size_t c = static_cast<size_t>(assign[i]);
    ++(*count)[c];
    for (int byte = 0; byte < 32; ++byte) packed[c][byte] += kBitsToBytes[descs[i][byte]];
    if (++in_packed[c] == 255) spill(c);
  }
  for (size_t c = 0; c < k; ++c) spill(c);
}

}  // namespace

Vocabulary Vocabulary::Build(const std::vector<const uint8_t*>& descriptors, int branching, int depth, unsigned seed) {
  Vocabulary v;
  v.nodes_.emplace_back();
  v.Split(0, descriptors, branching, depth, seed);
  return v;
}

void Vocabulary::Split(int node, std::vector<const uint8_t*> descs, int branching, int depth, unsigned seed) {
  if (depth == 0 || static_cast<int>(descs.size()) <= branching) {
    nodes_[node].word = words_++;
    return;
  }
  std::mt19937 rng(seed + static_cast<unsigned>(node) * 7919u);
  // k-means++ seeding on Hamming distance.
  std::vector<std::array<uint8_t, 32>> centers;
  std::vector<int> dmin(descs.size(), 256);
  {
    std::array<uint8_t, 32> c;
    std::memcpy(c.data(), descs[rng() % descs.size()], 32);
    centers.push_back(c);
  }
  while (static_cast<int>(centers.size()) < branching) {
    double total = 0;
    for (size_t i = 0; i < descs.size(); ++i) {
      dmin[i] = std::min(dmin[i], DescriptorDistance(descs[i], centers.back().data()));
      total += static_cast<double>(dmin[i]) * dmin[i];
    }
    if (total <= 0) break;
    const double r = std::uniform_real_distribution<double>(0, total)(rng);
    double acc = 0;
    size_t pick = descs.size() - 1;
    for (size_t i = 0; i < descs.size(); ++i) {
      acc += static_cast<double>(dmin[i]) * dmin[i];
      if (acc >= r) {
        pick = i;
        break;
      }
    }
    std::array<uint8_t, 32> c;
    std::memcpy(c.data(), descs[pick], 32);
    centers.push_back(c);
  }
  const int k = static_cast<int>(centers.size());
  std::vector<int> assign(descs.size(), 0);
  for (int iter = 0; iter < 6; ++iter) {
    // Each descriptor's nearest centre (independent per descriptor: the same assignment on any thread count).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, descs.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        int best = 257;
        for (int c = 0; c < k; ++c) {
          const int d = DescriptorDistance(descs[i], centers[c].data());
          if (d < best) {
            best = d;
            assign[i] = c;
          }
        }
      }
    });
    // k-majority: each bit of a centre is the majority of its members' bits.
    std::vector<std::array<int, 256>> ones(k);
    std::vector<int> count(k, 0);
    for (auto& o : ones) o.fill(0);
    CountBits(descs, assign, &ones, &count);
    for (int c = 0; c < k; ++c) {
      if (count[c] == 0) continue;
      centers[c].fill(0);
      for (int b = 0; b < 256; ++b)
        if (2 * ones[c][b] > count[c]) centers[c][b >> 3] |= static_cast<uint8_t>(1u << (b & 7));
    }
  }
  std::vector<std::vector<const uint8_t*>> parts(k);
  for (size_t i = 0; i < descs.size(); ++i) parts[assign[i]].push_back(descs[i]);
  for (int c = 0; c < k; ++c) {
    const int child = static_cast<int>(nodes_.size());
    nodes_.emplace_back();
    nodes_[child].center = centers[c];
    nodes_[node].children.push_back(child);
  }
  for (int c = 0; c < k; ++c) Split(nodes_[node].children[c], std::move(parts[c]), branching, depth - 1, seed);
}

int Vocabulary::Word(const uint8_t* d) const {
  int node = 0;
  while (nodes_[node].word < 0) {
    int best = 257, best_child = nodes_[node].children.front();
    for (int c : nodes_[node].children) {
      const int dist = DescriptorDistance(d, nodes_[c].center.data());
      if (dist < best) {
        best = dist;
        best_child = c;
      }
    }
    node = best_child;
  }
  return nodes_[node].word;
}

double BowScore(const BowVector& a, const BowVector& b) {
  // |a - b|_1 = |a|_1 + |b|_1 - sum over shared words (|a_w| + |b_w| - |a_w - b_w|), both normalised to 1.
  double shared = 0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      shared += std::abs(ia->second) + std::abs(ib->second) - std::abs(ia->second - ib->second);
      ++ia;
      ++ib;
    }
  }
  return 0.5 * shared;
}

std::vector<BowVector> BowVectors(const std::vector<std::vector<int>>& words_per_image, int vocabulary_words) {
  const size_t n = words_per_image.size();
  std::vector<int> df(vocabulary_words, 0);
  for (const auto& ws : words_per_image) {
    std::vector<int> u(ws);
    std::sort(u.begin(), u.end());
    u.erase(std::unique(u.begin(), u.end()), u.end());
    for (int w : u) ++df[w];
  }
  std::vector<BowVector> out(n);
  for (size_t i = 0; i < n; ++i) {
    BowVector& v = out[i];
    for (int w : words_per_image[i]) v[w] += 1.0;
    double sum = 0;
    for (auto& [w, x] : v) {
      x *= std::log(static_cast<double>(n) / df[w]);
      sum += x;
    }
    if (sum > 0)
      for (auto& [w, x] : v) x /= sum;
  }
  return out;
}

}  // namespace rs
