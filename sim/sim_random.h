#pragma once
// Portable deterministic randomness for the simulator. std:: distributions are
// implementation-defined, so the same seed could give different scenes with
// another standard library; these do not.

#include <cmath>
#include <cstdint>
#include <vector>

namespace rs::sim {

/// SplitMix64 finalizer: a high-quality 64-bit hash.
inline uint64_t Mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Hash of several integers (stream id, frame, pixel, ...).
inline uint64_t HashCombine(uint64_t a, uint64_t b) { return Mix64(a ^ (Mix64(b) + 0x632BE59BD9B4E019ull)); }

/// Sequential generator (SplitMix64 stream).
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(Mix64(seed)) {}
  uint64_t Next() { return Mix64(state_ += 0x9E3779B97F4A7C15ull); }
  /// Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double a, double b) { return a + (b - a) * Uniform(); }
  /// Standard normal (Box-Muller).
  double Normal() {
    const double u1 = 1.0 - Uniform();
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  /// Poisson-like count: the integer part of x plus one with probability frac(x).
  int Count(double x) {
    const int n = static_cast<int>(std::floor(x));
    return n + (Uniform() < x - n ? 1 : 0);
  }

 private:
  uint64_t state_;
};

/// A 1024x1024 tile of white noise in [0, 1], sampled bilinearly with wrap-around.
/// Octaves of the procedural texture sample it at different scales, rotations and
/// offsets, so patterns do not visibly repeat while each lookup stays cheap.
class NoiseTable {
 public:
  static constexpr int kBits = 10;
  static constexpr int kSize = 1 << kBits;
  static constexpr int kMask = kSize - 1;

  explicit NoiseTable(uint64_t seed) : v_(static_cast<size_t>(kSize) * kSize) {
    for (size_t i = 0; i < v_.size(); ++i) v_[i] = static_cast<uint8_t>(HashCombine(seed, i) >> 56);
  }
  /// Bilinear sample at texel coordinates (x, y), in [0, 1].
  float Sample(double x, double y) const {
    const double fx = std::floor(x), fy = std::floor(y);
    const float wx = static_cast<float>(x - fx), wy = static_cast<float>(y - fy);
    const int ix = static_cast<int>(static_cast<int64_t>(fx) & kMask);
    const int iy = static_cast<int>(static_cast<int64_t>(fy) & kMask);
    const int ix1 = (ix + 1) & kMask, iy1 = (iy + 1) & kMask;
    const uint8_t* r0 = &v_[static_cast<size_t>(iy) << kBits];
    const uint8_t* r1 = &v_[static_cast<size_t>(iy1) << kBits];
    const float a = r0[ix] + wx * (r0[ix1] - r0[ix]);
    const float b = r1[ix] + wx * (r1[ix1] - r1[ix]);
    return (a + wy * (b - a)) * (1.0f / 255.0f);
  }

 private:
  std::vector<uint8_t> v_;
};

/// One octave of texture: a rotated, scaled, offset view of the noise table.
struct Octave {
  Octave(double scale, double cos_a, double sin_a, double off_x, double off_y)
      : scale_m(scale), c(cos_a), s(sin_a), ox(off_x), oy(off_y), cu(cos_a / scale), su(sin_a / scale) {}
  double scale_m = 0.01;    ///< texel size on the ground
  double c = 1, s = 0;      ///< rotation cos/sin
  double ox = 0, oy = 0;    ///< offset, texels
  double cu = 100, su = 0;  ///< c / scale_m, s / scale_m: the renderer samples octaves per pixel, so no division there
  float At(const NoiseTable& t, double u, double v) const {
    const double x = cu * u - su * v + ox;
    const double y = su * u + cu * v + oy;
    return t.Sample(x, y);
  }
};

}  // namespace rs::sim
