#pragma once

/** \file
  * Shared pieces of the hand-vectorised kernels (see cpu_features.h for why they exist and
  * how they are chosen). Include only from .cpp files; everything here is compiled for
  * AVX2 + FMA through the target attribute, so callers must check vectorKernelsEnabled().
  */

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

/** Defined where the AVX2 kernels can be compiled (x86-64 with GCC or Clang). */
#define CUEFUSION_HAVE_AVX2_KERNELS 1
/** Compiles one function for AVX2 + FMA, leaving the rest of the file baseline x86-64. */
#define CUEFUSION_AVX2 __attribute__ ((target ("avx2,fma")))

namespace cuefusion
{
namespace avx2
{
/** \brief x, y, z of eight consecutive 3-float pixels (a CV_32FC3 row) starting at \a p. */
CUEFUSION_AVX2 inline void
loadXyz8 (const float* p, __m256& x, __m256& y, __m256& z)
{
  const __m256i stride3 = _mm256_setr_epi32 (0, 3, 6, 9, 12, 15, 18, 21);
  x = _mm256_i32gather_ps (p, stride3, 4);
  y = _mm256_i32gather_ps (p + 1, stride3, 4);
  z = _mm256_i32gather_ps (p + 2, stride3, 4);
}

/** \brief Lanes where \a lo ≤ i < \a hi for 32-bit integer lanes (all ones / zeros). */
CUEFUSION_AVX2 inline __m256i
inRange (__m256i i, int lo, int hi)
{
  return _mm256_and_si256 (_mm256_cmpgt_epi32 (i, _mm256_set1_epi32 (lo - 1)), _mm256_cmpgt_epi32 (_mm256_set1_epi32 (hi), i));
}

/** \brief |x| per lane. */
CUEFUSION_AVX2 inline __m256
abs (__m256 x)
{
  return _mm256_andnot_ps (_mm256_set1_ps (-0.f), x);
}
}  // namespace avx2
}  // namespace cuefusion
#endif
