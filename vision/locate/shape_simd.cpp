#include "vision/locate/shape_simd.hpp"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define VGR_SHAPE_X86 1
#endif

namespace vgr::vision::shape {
namespace {

void addScalar(const std::uint8_t* base, const std::int32_t* off, int count, int width, std::uint16_t* acc) {
  for (int k = 0; k < count; ++k) {
    const std::uint8_t* p = base + off[k];
    for (int x = 0; x < width; ++x) acc[x] = static_cast<std::uint16_t>(acc[x] + p[x]);
  }
}

#ifdef VGR_SHAPE_X86
// 8-bit saturating adds over the chunk (no saturation happens: count * kResponseMax < 256),
// then one widening add into the 16-bit accumulators. Two registers (64 positions) at a time.
__attribute__((target("avx2"))) void addAvx2(const std::uint8_t* base, const std::int32_t* off, int count, int width,
                                             std::uint16_t* acc) {
  int x = 0;
  for (; x < width; x += 64) {
    __m256i a0 = _mm256_setzero_si256(), a1 = _mm256_setzero_si256();
    for (int k = 0; k < count; ++k) {
      const std::uint8_t* p = base + off[k] + x;
      a0 = _mm256_adds_epu8(a0, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)));
      a1 = _mm256_adds_epu8(a1, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + 32)));
    }
    // Widen in order: the low and high 16 bytes of each register to 16 words.
    const __m256i* in[2] = {&a0, &a1};
    for (int h = 0; h < 2; ++h) {
      const int at = x + 32 * h;
      if (at >= width) break;
      __m256i* q = reinterpret_cast<__m256i*>(acc + at);
      const __m256i lo = _mm256_cvtepu8_epi16(_mm256_castsi256_si128(*in[h]));
      const __m256i hi = _mm256_cvtepu8_epi16(_mm256_extracti128_si256(*in[h], 1));
      _mm256_storeu_si256(q, _mm256_add_epi16(_mm256_loadu_si256(q), lo));
      _mm256_storeu_si256(q + 1, _mm256_add_epi16(_mm256_loadu_si256(q + 1), hi));
    }
  }
}

void addSse2(const std::uint8_t* base, const std::int32_t* off, int count, int width, std::uint16_t* acc) {
  const __m128i zero = _mm_setzero_si128();
  for (int x = 0; x < width; x += 32) {
    __m128i a0 = _mm_setzero_si128(), a1 = _mm_setzero_si128();
    for (int k = 0; k < count; ++k) {
      const std::uint8_t* p = base + off[k] + x;
      a0 = _mm_adds_epu8(a0, _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
      a1 = _mm_adds_epu8(a1, _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 16)));
    }
    const __m128i* in[2] = {&a0, &a1};
    for (int h = 0; h < 2; ++h) {
      const int at = x + 16 * h;
      if (at >= width) break;
      __m128i* q = reinterpret_cast<__m128i*>(acc + at);
      _mm_storeu_si128(q, _mm_add_epi16(_mm_loadu_si128(q), _mm_unpacklo_epi8(*in[h], zero)));
      _mm_storeu_si128(q + 1, _mm_add_epi16(_mm_loadu_si128(q + 1), _mm_unpackhi_epi8(*in[h], zero)));
    }
  }
}
#endif

using AddFn = void (*)(const std::uint8_t*, const std::int32_t*, int, int, std::uint16_t*);

struct Dispatch {
  AddFn fn = addScalar;
  const char* name = "scalar";
  Dispatch() {
#ifdef VGR_SHAPE_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2")) {
      fn = addAvx2, name = "avx2";
    } else {
      fn = addSse2, name = "sse2";
    }
#endif
  }
};

const Dispatch& dispatch() {
  static const Dispatch d;
  return d;
}

}  // namespace

// Plain code the compiler vectorises (this file is built with -fno-math-errno
// -fno-trapping-math, vision/CMakeLists.txt: sqrt and the select then become vector
// instructions); target_clones adds an AVX2 copy picked at load time.
#ifdef VGR_SHAPE_X86
__attribute__((target_clones("avx2", "default")))
#endif
void unitGradientRow(const std::uint8_t* __restrict a, const std::uint8_t* __restrict b, const std::uint8_t* __restrict c,
                     float* __restrict u, float* __restrict v, int x0, int x1, float thr2) {
  for (int x = x0; x < x1; ++x) {
    const int gx = (a[x + 1] - a[x - 1]) + 2 * (b[x + 1] - b[x - 1]) + (c[x + 1] - c[x - 1]);
    const int gy = (c[x - 1] + 2 * c[x] + c[x + 1]) - (a[x - 1] + 2 * a[x] + a[x + 1]);
    const float fx = static_cast<float>(gx), fy = static_cast<float>(gy);
    const float m2 = fx * fx + fy * fy;
    const float inv = 1.0f / std::sqrt(std::max(m2, 1.0f));
    const float k = m2 >= thr2 ? inv : 0.0f;
    u[x] = fx * k, v[x] = fy * k;
  }
}

void addResponses(const std::uint8_t* base, const std::int32_t* off, int count, int width, std::uint16_t* acc) {
  dispatch().fn(base, off, count, width, acc);
}

const char* responseSimd() { return dispatch().name; }

}  // namespace vgr::vision::shape
