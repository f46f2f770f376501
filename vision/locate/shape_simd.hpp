// The inner loop of the shape matcher's top-level search (shape_matcher.cpp): the sum of 8-bit
// similarity responses of a chunk of model points over a row of positions, in the x86 SIMD
// the CPU has, chosen once at run time (AVX2, else SSE2; the project compiles for baseline
// x86-64, so no -march flag may assume AVX2). Scalar elsewhere. Internal to vision/locate.
// Thread-safe (pure).
#pragma once

#include <cstdint>

namespace vgr::vision::shape {

// A response is the similarity of one model point with the image at one position, quantised
// to [0, kResponseMax]; kChunkPoints of them add up in 8 bits without saturating
// (16 * 15 = 240 < 256) before they are widened to 16 bits.
inline constexpr int kResponseMax = 15;
inline constexpr int kChunkPoints = 16;
// Bytes a row may be read past its last position (the caller's buffers have this slack).
inline constexpr int kReadSlack = 64;

// acc[x] += sum over k < count of base[off[k] + x], for x in [0, width); count <= kChunkPoints.
void addResponses(const std::uint8_t* base, const std::int32_t* off, int count, int width, std::uint16_t* acc);

// One row of the lower levels' unit gradient direction (Sobel 3x3): for x in [x0, x1), with
// a, b, c the rows above, at and below (x0 >= 1, x1 <= width - 1: the caller does the border
// columns), gx = (a[x+1] - a[x-1]) + 2 (b[x+1] - b[x-1]) + (c[x+1] - c[x-1]), gy likewise down
// the columns (8 x gray levels/px), and u, v = (gx, gy) / |(gx, gy)|, or 0 where
// gx^2 + gy^2 < thr2. Vectorised (AVX2 or SSE2 chosen at load time).
void unitGradientRow(const std::uint8_t* a, const std::uint8_t* b, const std::uint8_t* c, float* u, float* v, int x0,
                     int x1, float thr2);

// "avx2", "sse2" or "scalar": what addResponses runs (docs/performance.md names it).
const char* responseSimd();

}  // namespace vgr::vision::shape
