#pragma once
// Internal to the SGM core (sgm*.cc): the GCC vector types of one disparity chunk (kLanes x uint16)
// and the inline helpers on them (load/store, streaming store, minima, lane searches). Everything
// here is inline so that the path and winner kernels compile to straight vector code.

#include <algorithm>
#include <cstdint>
#include <cstring>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace rs::sgm_detail {

#if defined(__AVX512BW__)
constexpr int kLanes = 32;
#else
constexpr int kLanes = 16;
#endif
using v16 = uint16_t __attribute__((vector_size(2 * kLanes)));
using vs16 = int16_t __attribute__((vector_size(2 * kLanes)));
using v16u8 = uint8_t __attribute__((vector_size(kLanes)));

constexpr uint16_t kBig = 0x1000;  // padded lanes / sentinels; > MaxCost + 2 * p2 by Check()

inline v16 Load(const uint16_t* p) {
  v16 r;
  std::memcpy(&r, p, sizeof(r));
  return r;
}
inline void Store(uint16_t* p, v16 v) { std::memcpy(p, &v, sizeof(v)); }
// Non-temporal store (p aligned to the vector size): no read-for-ownership of the line and no
// cache pollution, for volume rows that are read back only after ~all the others.
inline void StoreStream(uint16_t* p, v16 v) {
#if defined(__AVX512BW__)
  _mm512_stream_si512(reinterpret_cast<__m512i*>(p), reinterpret_cast<__m512i>(v));
#elif defined(__AVX2__)
  _mm256_stream_si256(reinterpret_cast<__m256i*>(p), reinterpret_cast<__m256i>(v));
#else
  Store(p, v);
#endif
}
inline void StreamFence() {
#if defined(__AVX2__)
  _mm_sfence();
#endif
}
inline v16 LoadCost(const uint8_t* p) {
  v16u8 r;
  std::memcpy(&r, p, sizeof(r));
  return __builtin_convertvector(r, v16);
}
inline v16 VMin(v16 a, v16 b) { return a < b ? a : b; }
inline v16 Splat(uint16_t x) { return v16{} + x; }

inline uint16_t HMin(v16 v) {
#if defined(__AVX512BW__)
  // Upper half onto the lower by a lane shuffle (stays in registers; a memcpy split went
  // through the stack), then the AVX2/SSE4.1 reduction on the low 256 bits.
  using m16 = uint16_t __attribute__((vector_size(2 * kLanes)));
  constexpr m16 upper = {16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31,
                         16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31};
  const v16 folded = VMin(v, __builtin_shuffle(v, upper));
  __m256i x;  // low half; memcpy, as _mm512_castsi512_si256 trips a spurious GCC 12 warning
  std::memcpy(&x, &folded, sizeof(x));
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(x), _mm256_extracti128_si256(x, 1));
  return static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xFFFF);
#elif defined(__AVX2__)
  const __m256i x = reinterpret_cast<__m256i>(v);
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(x), _mm256_extracti128_si256(x, 1));
  return static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xFFFF);
#else
  uint16_t m = v[0];
  for (int i = 1; i < kLanes; ++i) m = std::min<uint16_t>(m, v[i]);
  return m;
#endif
}

// Index of the first lane equal to x, or -1.
inline int FirstEqual(v16 v, uint16_t x) {
#if defined(__AVX512BW__)
  const __mmask32 k = _mm512_cmpeq_epi16_mask(reinterpret_cast<__m512i>(v), _mm512_set1_epi16(static_cast<short>(x)));
  return k ? __builtin_ctz(k) : -1;
#elif defined(__AVX2__)
  const __m256i eq = _mm256_cmpeq_epi16(reinterpret_cast<__m256i>(v), _mm256_set1_epi16(static_cast<short>(x)));
  const unsigned mask = static_cast<unsigned>(_mm256_movemask_epi8(eq));
  return mask ? __builtin_ctz(mask) / 2 : -1;
#else
  for (int i = 0; i < kLanes; ++i)
    if (v[i] == x) return i;
  return -1;
#endif
}

// Bit i set where lane i <= t.
inline uint32_t LanesLe(v16 v, uint16_t t) {
#if defined(__AVX512BW__)
  return _mm512_cmple_epu16_mask(reinterpret_cast<__m512i>(v), _mm512_set1_epi16(static_cast<short>(t)));
#elif defined(__AVX2__) && defined(__BMI2__)
  const __m256i x = reinterpret_cast<__m256i>(v);
  const __m256i le = _mm256_cmpeq_epi16(_mm256_min_epu16(x, _mm256_set1_epi16(static_cast<short>(t))), x);
  return _pext_u32(static_cast<uint32_t>(_mm256_movemask_epi8(le)), 0x55555555u);
#else
  uint32_t m = 0;
  for (int i = 0; i < kLanes; ++i) m |= (v[i] <= t ? 1u : 0u) << i;
  return m;
#endif
}

}  // namespace rs::sgm_detail
