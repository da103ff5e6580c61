// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/** \file
  * Shared pieces of the hand-vectorised kernels (see cpu_features.h for why they exist and
  * how they are chosen). Include only from .cpp files; everything here is compiled for
  * AVX2 + FMA through the target attribute, so callers must check vectorKernelsEnabled().
  */

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <cuefusion/common/pinhole_camera.h>

#include <immintrin.h>

#include <cstddef>
#include <cstdint>

/** Defined where the AVX2 kernels can be compiled (x86-64 with GCC or Clang). */
#define CUEFUSION_HAVE_AVX2_KERNELS 1
/** Compiles one function for AVX2 + FMA, leaving the rest of the file baseline x86-64. */
#define CUEFUSION_AVX2 __attribute__ ((target ("avx2,fma")))
/** Compiles a plain C++ loop twice, for AVX2 (without FMA, so both compute the same bits)
  * and baseline x86-64; the loader picks the clone for the CPU, whatever
  * setVectorKernelsEnabled says. target_clones makes an ifunc whose resolver runs while the
  * program is loaded, before ThreadSanitizer's runtime is ready (a TSan build crashes at
  * start-up): no clones there. */
#if defined(__SANITIZE_THREAD__)
#define CUEFUSION_AVX2_CLONES
#else
#define CUEFUSION_AVX2_CLONES __attribute__ ((target_clones ("avx2", "default")))
#endif

namespace cuefusion
{
namespace avx2
{
/** \brief KinectNoiseModel::atNormalIncidence in eight lanes, in the same operations, so
  * the result is the scalar one bit for bit. The scalar form rounds the product before the
  * sum; GCC would fuse the two intrinsics into one FMA here (-ffp-contract=fast is its
  * default), so an empty asm statement hides the product from that contraction.
  */
CUEFUSION_AVX2 inline __m256
kinectNoiseAtNormalIncidence (__m256 z)
{
  const __m256 dz = _mm256_sub_ps (z, _mm256_set1_ps (static_cast<float> (KinectNoiseModel::offset)));
  __m256 quadratic = _mm256_mul_ps (_mm256_mul_ps (_mm256_set1_ps (static_cast<float> (KinectNoiseModel::quadratic)), dz), dz);
  __asm__ ("" : "+x"(quadratic));
  return _mm256_add_ps (_mm256_set1_ps (static_cast<float> (KinectNoiseModel::base)), quadratic);
}

/** \brief x, y, z of eight consecutive 3-float pixels (a CV_32FC3 row) starting at \a p:
  * three loads, two blends and a permute per coordinate (gathers were slower: AMD's
  * gather issues one load per lane).
  */
CUEFUSION_AVX2 inline void
loadXyz8 (const float* p, __m256& x, __m256& y, __m256& z)
{
  const __m256 a = _mm256_loadu_ps (p);       // x0 y0 z0 x1 y1 z1 x2 y2
  const __m256 b = _mm256_loadu_ps (p + 8);   // z2 x3 y3 z3 x4 y4 z4 x5
  const __m256 c = _mm256_loadu_ps (p + 16);  // y5 z5 x6 y6 z6 x7 y7 z7
  // Blends put every coordinate's eight values into one register, out of order; a
  // permute sorts them.
  x = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a, b, 0x92), c, 0x24),
                                _mm256_setr_epi32 (0, 3, 6, 1, 4, 7, 2, 5));
  y = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a, b, 0x24), c, 0x49),
                                _mm256_setr_epi32 (1, 4, 7, 2, 5, 0, 3, 6));
  z = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a, b, 0x49), c, 0x92),
                                _mm256_setr_epi32 (2, 5, 0, 3, 6, 1, 4, 7));
}

/** \brief The inverse of loadXyz8: stores eight x, y, z as 24 interleaved floats at \a p. */
CUEFUSION_AVX2 inline void
storeXyz8 (float* p, __m256 x, __m256 y, __m256 z)
{
  const __m256 tx = _mm256_permutevar8x32_ps (x, _mm256_setr_epi32 (0, 3, 6, 1, 4, 7, 2, 5));
  const __m256 ty = _mm256_permutevar8x32_ps (y, _mm256_setr_epi32 (5, 0, 3, 6, 1, 4, 7, 2));
  const __m256 tz = _mm256_permutevar8x32_ps (z, _mm256_setr_epi32 (2, 5, 0, 3, 6, 1, 4, 7));
  _mm256_storeu_ps (p, _mm256_blend_ps (_mm256_blend_ps (tx, ty, 0x92), tz, 0x24));
  _mm256_storeu_ps (p + 8, _mm256_blend_ps (_mm256_blend_ps (tx, ty, 0x24), tz, 0x49));
  _mm256_storeu_ps (p + 16, _mm256_blend_ps (_mm256_blend_ps (tx, ty, 0x49), tz, 0x92));
}

/** \brief Eight lanes of four floats each, r[i] holding lane i in its low half and lane
  * i + 4 in its high half, as four vectors of one float per lane (c_k = float k).
  */
CUEFUSION_AVX2 inline void
transposeHalves (const __m256 (&r)[4], __m256& c0, __m256& c1, __m256& c2, __m256& c3)
{
  const __m256 t0 = _mm256_unpacklo_ps (r[0], r[1]), t1 = _mm256_unpackhi_ps (r[0], r[1]);
  const __m256 t2 = _mm256_unpacklo_ps (r[2], r[3]), t3 = _mm256_unpackhi_ps (r[2], r[3]);
  c0 = _mm256_shuffle_ps (t0, t2, 0x44);
  c1 = _mm256_shuffle_ps (t0, t2, 0xee);
  c2 = _mm256_shuffle_ps (t1, t3, 0x44);
  c3 = _mm256_shuffle_ps (t1, t3, 0xee);
}

/** \brief x, y, z of eight 3-float pixels at \a base + offsets[i] (floats), for pixels
  * scattered over an image: a masked 3-float load per lane and a transpose. On AMD Zen 4
  * this is faster than three AVX2 gathers, which issue one load per lane each (ICP's
  * association: tracking 4.0–4.1 → 3.7 ms a frame on 7-Scenes, A/B). The masked load reads
  * nothing past the third float, so the image's last pixel is safe.
  */
CUEFUSION_AVX2 inline void
gatherXyz8 (const float* base, const std::int32_t* offsets, __m256& x, __m256& y, __m256& z)
{
  const __m128i xyz = _mm_setr_epi32 (-1, -1, -1, 0);
  __m256 r[4];
  for (int i = 0; i < 4; ++i)
    r[i] = _mm256_insertf128_ps (_mm256_castps128_ps256 (_mm_maskload_ps (base + offsets[i], xyz)),
                                 _mm_maskload_ps (base + offsets[i + 4], xyz), 1);
  __m256 unused;
  transposeHalves (r, x, y, z, unused);
}

/** \brief The 2 × 2 pixels at \a base + offsets[i] (floats; the pixel, its right
  * neighbour, and the two below, \a row_step floats further) of eight lanes: two 8-byte
  * loads per lane and a transpose, in place of four AVX2 gathers (bilinear depth in the
  * TSDF integration).
  */
CUEFUSION_AVX2 inline void
gatherQuads8 (const float* base, const std::int32_t* offsets, std::ptrdiff_t row_step, __m256& top_left, __m256& top_right,
              __m256& bottom_left, __m256& bottom_right)
{
  const auto quad = [&] (int i) {
    const float* p = base + offsets[i];
    return _mm_castsi128_ps (_mm_unpacklo_epi64 (_mm_loadl_epi64 (reinterpret_cast<const __m128i*> (p)),
                                                 _mm_loadl_epi64 (reinterpret_cast<const __m128i*> (p + row_step))));
  };
  __m256 r[4];
  for (int i = 0; i < 4; ++i)
    r[i] = _mm256_insertf128_ps (_mm256_castps128_ps256 (quad (i)), quad (i + 4), 1);
  transposeHalves (r, top_left, top_right, bottom_left, bottom_right);
}

/** \brief Lanes where 0 ≤ u < width and 0 ≤ v < height (all ones / zeros); a lane holding
  * INT_MIN (what an out-of-range float converts to) is outside.
  */
CUEFUSION_AVX2 inline __m256i
insideImage (__m256i u, __m256i v, int width, int height)
{
  const __m256i minus_one = _mm256_set1_epi32 (-1);
  return _mm256_and_si256 (
      _mm256_and_si256 (_mm256_cmpgt_epi32 (u, minus_one), _mm256_cmpgt_epi32 (_mm256_set1_epi32 (width), u)),
      _mm256_and_si256 (_mm256_cmpgt_epi32 (v, minus_one), _mm256_cmpgt_epi32 (_mm256_set1_epi32 (height), v)));
}

/** \brief The pinhole projection of eight camera-frame points, as the voxel kernels
  * (integration, the label update) do it per voxel: uf = fx·x·(1/z) + cx, vf likewise,
  * and the nearest pixel (u, v) = ⌊(uf, vf) + ½⌋. Returns the lanes with z > 0 whose
  * pixel lies in the image.
  */
CUEFUSION_AVX2 inline __m256
projectToPixel8 (__m256 x, __m256 y, __m256 z, const FloatIntrinsics& camera, __m256& uf, __m256& vf, __m256i& u,
                 __m256i& v)
{
  const __m256 inv_z = _mm256_div_ps (_mm256_set1_ps (1.f), z);
  uf = _mm256_add_ps (_mm256_mul_ps (_mm256_mul_ps (_mm256_set1_ps (camera.fx), x), inv_z), _mm256_set1_ps (camera.cx));
  vf = _mm256_add_ps (_mm256_mul_ps (_mm256_mul_ps (_mm256_set1_ps (camera.fy), y), inv_z), _mm256_set1_ps (camera.cy));
  const __m256 half = _mm256_set1_ps (0.5f);
  u = _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (uf, half)));
  v = _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (vf, half)));
  return _mm256_and_ps (_mm256_cmp_ps (z, _mm256_setzero_ps (), _CMP_GT_OQ),
                        _mm256_castsi256_ps (insideImage (u, v, camera.width, camera.height)));
}

/** \brief Lanes where x, y and z are all finite (x − x is 0 for finite x, NaN for NaN
  * and ±inf).
  */
CUEFUSION_AVX2 inline __m256
finite (__m256 x, __m256 y, __m256 z)
{
  const __m256 sum = _mm256_add_ps (_mm256_add_ps (_mm256_sub_ps (x, x), _mm256_sub_ps (y, y)), _mm256_sub_ps (z, z));
  return _mm256_cmp_ps (sum, _mm256_setzero_ps (), _CMP_EQ_OQ);
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

#ifndef CUEFUSION_AVX2_CLONES
#define CUEFUSION_AVX2_CLONES
#endif
