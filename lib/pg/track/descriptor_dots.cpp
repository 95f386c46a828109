#include "pg/track/descriptor_dots.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PG_DOTS_AVX2 1
#endif

namespace pg {

namespace {

// Eight partial sums, one per lane of the vector kernel, so both paths add in the same order.
float dot_portable(const float* a, const float* b, int dims) {
  float lane[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int k = 0;
  for (; k + 8 <= dims; k += 8)
    for (int l = 0; l < 8; ++l) lane[l] += a[k + l] * b[k + l];
  float sum = ((lane[0] + lane[4]) + (lane[2] + lane[6])) + ((lane[1] + lane[5]) + (lane[3] + lane[7]));
  for (; k < dims; ++k) sum += a[k] * b[k];
  return sum;
}

#ifdef PG_DOTS_AVX2
// The target attribute compiles only these functions for AVX2: nothing else in the build depends on
// it, and they run only after the processor check below.
__attribute__((target("avx2,fma"))) float horizontal_sum(__m256 v) {
  const __m128 halves = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));  // l, l + 4
  const __m128 pairs = _mm_add_ps(halves, _mm_movehl_ps(halves, halves));  // (l0+l4)+(l2+l6), ...
  return _mm_cvtss_f32(_mm_add_ss(pairs, _mm_shuffle_ps(pairs, pairs, 1)));
}

__attribute__((target("avx2,fma"))) float dot_avx2(const float* a, const float* b, int dims) {
  __m256 acc = _mm256_setzero_ps();
  int k = 0;
  for (; k + 8 <= dims; k += 8) acc = _mm256_fmadd_ps(_mm256_loadu_ps(a + k), _mm256_loadu_ps(b + k), acc);
  float sum = horizontal_sum(acc);
  for (; k < dims; ++k) sum += a[k] * b[k];
  return sum;
}

// Four rows of a against two of b at a time: eight accumulators, six loads per eight FMAs.
__attribute__((target("avx2,fma"))) void dots_avx2(const float* a, int a_rows, const float* b, int b_rows,
                                                   int dims, float* out, int out_stride) {
  const int vector_dims = dims / 8 * 8;
  int i = 0;
  for (; i + 4 <= a_rows; i += 4) {
    const float* a0 = a + static_cast<long>(i) * dims;
    const float *a1 = a0 + dims, *a2 = a1 + dims, *a3 = a2 + dims;
    int j = 0;
    for (; j + 2 <= b_rows; j += 2) {
      const float* b0 = b + static_cast<long>(j) * dims;
      const float* b1 = b0 + dims;
      __m256 c00 = _mm256_setzero_ps(), c01 = c00, c10 = c00, c11 = c00, c20 = c00, c21 = c00, c30 = c00,
             c31 = c00;
      for (int k = 0; k < vector_dims; k += 8) {
        const __m256 v0 = _mm256_loadu_ps(b0 + k), v1 = _mm256_loadu_ps(b1 + k);
        __m256 u = _mm256_loadu_ps(a0 + k);
        c00 = _mm256_fmadd_ps(u, v0, c00), c01 = _mm256_fmadd_ps(u, v1, c01);
        u = _mm256_loadu_ps(a1 + k);
        c10 = _mm256_fmadd_ps(u, v0, c10), c11 = _mm256_fmadd_ps(u, v1, c11);
        u = _mm256_loadu_ps(a2 + k);
        c20 = _mm256_fmadd_ps(u, v0, c20), c21 = _mm256_fmadd_ps(u, v1, c21);
        u = _mm256_loadu_ps(a3 + k);
        c30 = _mm256_fmadd_ps(u, v0, c30), c31 = _mm256_fmadd_ps(u, v1, c31);
      }
      float sums[8] = {horizontal_sum(c00), horizontal_sum(c01), horizontal_sum(c10), horizontal_sum(c11),
                       horizontal_sum(c20), horizontal_sum(c21), horizontal_sum(c30), horizontal_sum(c31)};
      const float* rows[4] = {a0, a1, a2, a3};
      for (int r = 0; r < 4; ++r) {
        for (int k = vector_dims; k < dims; ++k) {
          sums[2 * r] += rows[r][k] * b0[k];
          sums[2 * r + 1] += rows[r][k] * b1[k];
        }
        out[static_cast<long>(i + r) * out_stride + j] = sums[2 * r];
        out[static_cast<long>(i + r) * out_stride + j + 1] = sums[2 * r + 1];
      }
    }
    for (; j < b_rows; ++j)
      for (int r = 0; r < 4; ++r)
        out[static_cast<long>(i + r) * out_stride + j] =
            dot_avx2(a0 + static_cast<long>(r) * dims, b + static_cast<long>(j) * dims, dims);
  }
  for (; i < a_rows; ++i)
    for (int j = 0; j < b_rows; ++j)
      out[static_cast<long>(i) * out_stride + j] =
          dot_avx2(a + static_cast<long>(i) * dims, b + static_cast<long>(j) * dims, dims);
}
#endif

}  // namespace

void descriptor_dots_portable(const float* a, int a_rows, const float* b, int b_rows, int dims, float* out,
                              int out_stride) {
  for (int i = 0; i < a_rows; ++i)
    for (int j = 0; j < b_rows; ++j)
      out[static_cast<long>(i) * out_stride + j] =
          dot_portable(a + static_cast<long>(i) * dims, b + static_cast<long>(j) * dims, dims);
}

bool descriptor_dots_vectorised() {
#ifdef PG_DOTS_AVX2
  static const bool available = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return available;
#else
  return false;
#endif
}

void descriptor_dots(const float* a, int a_rows, const float* b, int b_rows, int dims, float* out,
                     int out_stride) {
#ifdef PG_DOTS_AVX2
  if (descriptor_dots_vectorised()) return dots_avx2(a, a_rows, b, b_rows, dims, out, out_stride);
#endif
  descriptor_dots_portable(a, a_rows, b, b_rows, dims, out, out_stride);
}

}  // namespace pg
