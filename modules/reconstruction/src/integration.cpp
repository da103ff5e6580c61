// SPDX-License-Identifier: BSD-3-Clause
#include "integration.h"

#include <cuefusion/common/avx2.h>
#include <cuefusion/common/sensor_defaults.h>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace cuefusion
{
namespace reconstruction
{
namespace detail
{
namespace
{
/// Four pixels are one surface for the bilinear depth when within this × the nearest
/// depth of each other (2 %, the scalar and the AVX2 kernel alike).
constexpr float kSameSurface = kSurfaceDepthJump;

/** \brief Depth seen along the voxel's own ray: bilinear between the four pixels around
  * (uf, vf) when all are valid and on one surface (within 2 % of each other), else the
  * nearest pixel (u, v); 0 when the nearest pixel has no usable depth. Looking up only
  * the nearest pixel leaves a staircase of up to half a pixel's depth slope in the
  * distances, which on slanted surfaces far away is several millimetres.
  */
inline float
interpolatedDepth (const IntegrationFrame& f, float uf, float vf, int u, int v)
{
  const float nearest = f.depth[static_cast<std::size_t> (v) * f.depth_step + static_cast<std::size_t> (u)];
  if (!usableDepth (nearest, f.min_depth, f.max_depth))
    return 0.f;
  const int u0 = fastFloor (uf), v0 = fastFloor (vf);
  if (u0 < 0 || v0 < 0 || u0 + 1 >= f.camera.width || v0 + 1 >= f.camera.height)
    return nearest;
  const float* r0 = f.depth + static_cast<std::size_t> (v0) * f.depth_step + u0;
  const float* r1 = r0 + f.depth_step;
  const float d00 = r0[0], d01 = r0[1], d10 = r1[0], d11 = r1[1];
  if (!(usableDepth (d00, f.min_depth, f.max_depth) && usableDepth (d01, f.min_depth, f.max_depth) &&
        usableDepth (d10, f.min_depth, f.max_depth) && usableDepth (d11, f.min_depth, f.max_depth)))
    return nearest;
  const float lo = std::min (std::min (d00, d01), std::min (d10, d11));
  const float hi = std::max (std::max (d00, d01), std::max (d10, d11));
  if (!(hi - lo <= kSameSurface * lo))
    return nearest;
  const float a = uf - static_cast<float> (u0), b = vf - static_cast<float> (v0);
  return (d00 * (1.f - a) + d01 * a) * (1.f - b) + (d10 * (1.f - a) + d11 * a) * b;
}
}  // namespace

void
integrateBlockScalar (VoxelBlock& block, const IntegrationFrame& f, std::uint32_t first_voxel,
                      std::vector<SurfaceObservation>* observed)
{
  const Eigen::Vector3f origin = f.R_cw * (block.index.cast<float> () * (kBlockSide * f.voxel_size)) + f.t_cw;
  const Eigen::Vector3f dx = f.R_cw.col (0) * f.voxel_size;
  const Eigen::Vector3f dy = f.R_cw.col (1) * f.voxel_size;
  const Eigen::Vector3f dz = f.R_cw.col (2) * f.voxel_size;
  for (int z = 0; z < kBlockSide; ++z)
    for (int y = 0; y < kBlockSide; ++y)
    {
      const Eigen::Vector3f row = origin + dy * static_cast<float> (y) + dz * static_cast<float> (z);
      const int first = localVoxelIndex (0, y, z);
      for (int x = 0; x < kBlockSide; ++x)
      {
        const Eigen::Vector3f p = row + dx * static_cast<float> (x);
        if (p.z () <= 0.f)
          continue;
        const float inv_z = 1.f / p.z ();
        const float uf = f.camera.fx * p.x () * inv_z + f.camera.cx, vf = f.camera.fy * p.y () * inv_z + f.camera.cy;
        const int u = fastFloor (uf + 0.5f), v = fastFloor (vf + 0.5f);
        if (u < 0 || v < 0 || u >= f.camera.width || v >= f.camera.height)
          continue;
        const float d = interpolatedDepth (f, uf, vf, u, v);
        float tsdf;
        if (d == 0.f || !projectiveTsdf (d, p.z (), f.truncation, tsdf))
          continue;
        const std::size_t i = static_cast<std::size_t> (first + x);
        updateVoxel (block.voxels[i], tsdf,
                     f.color != nullptr ? f.color + static_cast<std::size_t> (v) * f.color_step + 3 * u : nullptr,
                     f.max_weight);
        block.distances[static_cast<std::size_t> (distanceIndex (x, y, z))] = encodeDistance (block.voxels[i]);
        if (observed != nullptr)
        {
          const float gap = std::abs (p.z () - f.depth[static_cast<std::size_t> (v) * f.depth_step + static_cast<std::size_t> (u)]);
          if (gap < f.truncation && std::abs (block.voxels[i].sdf) < 1.f)
            observed->push_back ({first_voxel + static_cast<std::uint32_t> (i),
                                  static_cast<std::uint32_t> (v) << 16 | static_cast<std::uint32_t> (u), gap, block.voxels[i].sdf});
        }
      }
    }
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
namespace
{
/** \brief usableDepth per lane. */
CUEFUSION_AVX2 inline __m256
usableDepth8 (__m256 d, __m256 min_depth, __m256 max_depth)
{
  return _mm256_and_ps (_mm256_cmp_ps (d, min_depth, _CMP_GE_OQ), _mm256_cmp_ps (d, max_depth, _CMP_LE_OQ));
}

/** \brief Eight consecutive 12-byte voxels at \a p (three unaligned loads) as three vectors
  * of their 32-bit fields: sdf, weight and the colour word (r, g, b, reserved), lane i
  * holding voxel i.
  *
  * The 24 floats repeat sdf, weight, colour, so each load holds every field at lanes three
  * apart, and the lanes of one field across the three loads do not collide (sdf: lanes 0 3 6
  * of the first, 1 4 7 of the second, 2 5 of the third): two blends gather a field, one
  * permute puts it in voxel order.
  */
CUEFUSION_AVX2 inline void
loadVoxels8 (const float* p, __m256& sdf, __m256& weight, __m256& color)
{
  static_assert (sizeof (TsdfVoxel) == 12 && offsetof (TsdfVoxel, weight) == 4 && offsetof (TsdfVoxel, r) == 8,
                 "loadVoxels8 assumes TsdfVoxel's layout");
  const __m256 a0 = _mm256_loadu_ps (p), a1 = _mm256_loadu_ps (p + 8), a2 = _mm256_loadu_ps (p + 16);
  sdf = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a0, a1, 0x92), a2, 0x24),
                                  _mm256_setr_epi32 (0, 3, 6, 1, 4, 7, 2, 5));
  weight = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a0, a1, 0x24), a2, 0x49),
                                     _mm256_setr_epi32 (1, 4, 7, 2, 5, 0, 3, 6));
  color = _mm256_permutevar8x32_ps (_mm256_blend_ps (_mm256_blend_ps (a0, a1, 0x49), a2, 0x92),
                                    _mm256_setr_epi32 (2, 5, 0, 3, 6, 1, 4, 7));
}

/** \brief The inverse of loadVoxels8. */
CUEFUSION_AVX2 inline void
storeVoxels8 (float* p, __m256 sdf, __m256 weight, __m256 color)
{
  const __m256 s = _mm256_permutevar8x32_ps (sdf, _mm256_setr_epi32 (0, 3, 6, 1, 4, 7, 2, 5));
  const __m256 w = _mm256_permutevar8x32_ps (weight, _mm256_setr_epi32 (5, 0, 3, 6, 1, 4, 7, 2));
  const __m256 c = _mm256_permutevar8x32_ps (color, _mm256_setr_epi32 (2, 5, 0, 3, 6, 1, 4, 7));
  _mm256_storeu_ps (p, _mm256_blend_ps (_mm256_blend_ps (s, w, 0x92), c, 0x24));
  _mm256_storeu_ps (p + 8, _mm256_blend_ps (_mm256_blend_ps (s, w, 0x24), c, 0x49));
  _mm256_storeu_ps (p + 16, _mm256_blend_ps (_mm256_blend_ps (s, w, 0x49), c, 0x92));
}

/** \brief updateVoxel's colour average of one channel (0–255 in 32-bit lanes). */
CUEFUSION_AVX2 inline __m256i
averageChannel (__m256i old_channel, __m256i observed, __m256 w, __m256 w_new)
{
  const __m256 old_f = _mm256_cvtepi32_ps (old_channel);
  const __m256 obs_f = _mm256_cvtepi32_ps (observed);
  const __m256 mean = _mm256_add_ps (_mm256_div_ps (_mm256_add_ps (_mm256_mul_ps (w, old_f), obs_f), w_new),
                                     _mm256_set1_ps (0.5f));
  return _mm256_and_si256 (_mm256_cvttps_epi32 (mean), _mm256_set1_epi32 (0xff));
}
}  // namespace

/** The depth each of eight voxels' projections (uf, vf; nearest pixel u, v; \a seen: in
  * front of the camera and inside the image) sees: bilinear where the four pixels around it
  * are usable and close, else the nearest pixel. \a nearest_ok: lanes whose nearest pixel
  * is usable (others are not updated); when none is, returns at once. */
CUEFUSION_AVX2 inline __m256
sampleDepth8 (const IntegrationFrame& f, __m256 seen, __m256 uf, __m256 vf, __m256i u, __m256i v, __m256& nearest, __m256& nearest_ok)
{
  const __m256 zero = _mm256_setzero_ps (), one = _mm256_set1_ps (1.f);
  const __m256 min_depth = _mm256_set1_ps (f.min_depth), max_depth = _mm256_set1_ps (f.max_depth);
  const __m256 same_surface = _mm256_set1_ps (kSameSurface);
  const __m256i depth_step = _mm256_set1_epi32 (static_cast<int> (f.depth_step));
  // The 2×2 pixels around each projection, read once: the nearest pixel (u, v) is one of
  // them, ⌊uf + ½⌋ being ⌊uf⌋ or ⌊uf⌋ + 1. Only lanes whose quad leaves the image (a
  // half-pixel border) gather the nearest pixel alone. A gather of the nearest pixels
  // ahead of the quads was a tenth of this kernel's time, waiting for its loads.
  const __m256 uf0 = _mm256_floor_ps (uf), vf0 = _mm256_floor_ps (vf);
  const __m256i u0 = _mm256_cvttps_epi32 (uf0), v0 = _mm256_cvttps_epi32 (vf0);
  const __m256 corners_inside = _mm256_castsi256_ps (avx2::insideImage (u0, v0, f.camera.width - 1, f.camera.height - 1));
  const __m256 quad_lanes = _mm256_and_ps (seen, corners_inside);
  __m256 d00 = zero, d01 = zero, d10 = zero, d11 = zero;
  nearest = zero;
  if (_mm256_movemask_ps (quad_lanes) != 0)
  {
    // Lanes without a quad in the image read the image's first one (offset 0); their
    // values are replaced or masked out below.
    alignas (32) std::int32_t quad_offset[8];
    _mm256_store_si256 (reinterpret_cast<__m256i*> (quad_offset),
                        _mm256_and_si256 (_mm256_add_epi32 (_mm256_mullo_epi32 (v0, depth_step), u0),
                                          _mm256_castps_si256 (quad_lanes)));
    avx2::gatherQuads8 (f.depth, quad_offset, static_cast<std::ptrdiff_t> (f.depth_step), d00, d01, d10, d11);
    const __m256 right = _mm256_castsi256_ps (_mm256_cmpeq_epi32 (u, _mm256_add_epi32 (u0, _mm256_set1_epi32 (1))));
    const __m256 below = _mm256_castsi256_ps (_mm256_cmpeq_epi32 (v, _mm256_add_epi32 (v0, _mm256_set1_epi32 (1))));
    nearest = _mm256_and_ps (quad_lanes, _mm256_blendv_ps (_mm256_blendv_ps (d00, d01, right), _mm256_blendv_ps (d10, d11, right), below));
  }
  const __m256 border_lanes = _mm256_andnot_ps (corners_inside, seen);
  if (_mm256_movemask_ps (border_lanes) != 0)
    nearest = _mm256_mask_i32gather_ps (nearest, f.depth, _mm256_add_epi32 (_mm256_mullo_epi32 (v, depth_step), u), border_lanes, 4);
  nearest_ok = _mm256_and_ps (
      seen, _mm256_and_ps (_mm256_cmp_ps (nearest, min_depth, _CMP_GE_OQ), _mm256_cmp_ps (nearest, max_depth, _CMP_LE_OQ)));
  if (_mm256_movemask_ps (nearest_ok) == 0)
    return zero;

  // Bilinear depth where the four pixels around the projection are usable and close.
  __m256 bilinear_ok = _mm256_and_ps (nearest_ok, corners_inside);
  __m256 depth = nearest;
  if (_mm256_movemask_ps (bilinear_ok) != 0)
  {
    const __m256 lo = _mm256_min_ps (_mm256_min_ps (d00, d01), _mm256_min_ps (d10, d11));
    const __m256 hi = _mm256_max_ps (_mm256_max_ps (d00, d01), _mm256_max_ps (d10, d11));
    bilinear_ok = _mm256_and_ps (
        _mm256_and_ps (bilinear_ok, _mm256_and_ps (_mm256_and_ps (usableDepth8 (d00, min_depth, max_depth), usableDepth8 (d01, min_depth, max_depth)),
                                                   _mm256_and_ps (usableDepth8 (d10, min_depth, max_depth), usableDepth8 (d11, min_depth, max_depth)))),
        _mm256_cmp_ps (_mm256_sub_ps (hi, lo), _mm256_mul_ps (same_surface, lo), _CMP_LE_OQ));
    const __m256 a = _mm256_sub_ps (uf, uf0), b = _mm256_sub_ps (vf, vf0);
    const __m256 na = _mm256_sub_ps (one, a), nb = _mm256_sub_ps (one, b);
    const __m256 top = _mm256_add_ps (_mm256_mul_ps (d00, na), _mm256_mul_ps (d01, a));
    const __m256 bottom = _mm256_add_ps (_mm256_mul_ps (d10, na), _mm256_mul_ps (d11, a));
    const __m256 blended = _mm256_add_ps (_mm256_mul_ps (top, nb), _mm256_mul_ps (bottom, b));
    depth = _mm256_blendv_ps (nearest, blended, bilinear_ok);
  }
  return depth;
}

/** The colour words of eight voxels after fusing the frame's colour at their pixels
  * (u, v) into their running average (weights \a w before, \a w_new after); the top byte,
  * TsdfVoxel::reserved, is kept. Lanes not in \a update read pixel 0 (their result is unused). */
CUEFUSION_AVX2 inline __m256i
fuseColor8 (const IntegrationFrame& f, __m256 update, __m256i u, __m256i v, __m256i word, __m256 w, __m256 w_new)
{
  alignas (32) std::int32_t color_offset[8];
  // Each lane's pixel as one BGR word, read through byte offsets (0 for lanes not
  // updated, whose pixel may lie outside the image) and set as a vector: filling
  // per-channel arrays with scalar stores and loading them as vectors stalled on
  // store forwarding (a tenth of this kernel).
  const __m256i offset = _mm256_add_epi32 (_mm256_mullo_epi32 (v, _mm256_set1_epi32 (static_cast<int> (f.color_step))),
                                           _mm256_mullo_epi32 (u, _mm256_set1_epi32 (3)));
  _mm256_store_si256 (reinterpret_cast<__m256i*> (color_offset), _mm256_and_si256 (offset, _mm256_castps_si256 (update)));
  const auto bgr_word = [&] (int i) {
    const std::uint8_t* bgr = f.color + color_offset[i];
    return static_cast<int> (bgr[0] | bgr[1] << 8 | bgr[2] << 16);
  };
  const __m256i observed_bgr = _mm256_setr_epi32 (bgr_word (0), bgr_word (1), bgr_word (2), bgr_word (3), bgr_word (4),
                                                  bgr_word (5), bgr_word (6), bgr_word (7));
  const __m256i byte = _mm256_set1_epi32 (0xff);
  const __m256i r = averageChannel (_mm256_and_si256 (word, byte), _mm256_srli_epi32 (observed_bgr, 16), w, w_new);
  const __m256i g = averageChannel (_mm256_and_si256 (_mm256_srli_epi32 (word, 8), byte),
                                    _mm256_and_si256 (_mm256_srli_epi32 (observed_bgr, 8), byte), w, w_new);
  const __m256i b = averageChannel (_mm256_and_si256 (_mm256_srli_epi32 (word, 16), byte),
                                    _mm256_and_si256 (observed_bgr, byte), w, w_new);
  // The top byte is TsdfVoxel::reserved: kept.
  return _mm256_or_si256 (_mm256_and_si256 (word, _mm256_set1_epi32 (static_cast<int> (0xff000000u))),
                          _mm256_or_si256 (_mm256_or_si256 (r, _mm256_slli_epi32 (g, 8)), _mm256_slli_epi32 (b, 16)));
}

// The arithmetic below is the scalar version's, lane by lane: the same divisions (not
// reciprocals) and the same order of operations, so both paths agree to the last bit for
// a voxel that lands on the same pixel. Only the voxel positions differ in rounding (row
// origin + x · dx in one FMA instead of stepping).
CUEFUSION_AVX2 void
integrateBlockAvx2 (VoxelBlock& block, const IntegrationFrame& f, std::uint32_t first_voxel,
                    std::vector<SurfaceObservation>* observed)
{
  const Eigen::Vector3f origin = f.R_cw * (block.index.cast<float> () * (kBlockSide * f.voxel_size)) + f.t_cw;
  const Eigen::Vector3f dx = f.R_cw.col (0) * f.voxel_size;
  const Eigen::Vector3f dy = f.R_cw.col (1) * f.voxel_size;
  const Eigen::Vector3f dz = f.R_cw.col (2) * f.voxel_size;

  const __m256 lane = _mm256_setr_ps (0.f, 1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f);
  const __m256 zero = _mm256_setzero_ps (), one = _mm256_set1_ps (1.f), half = _mm256_set1_ps (0.5f);
  const __m256 truncation = _mm256_set1_ps (f.truncation), neg_truncation = _mm256_set1_ps (-f.truncation);
  const __m256 max_weight = _mm256_set1_ps (f.max_weight);
  const __m256 lx = _mm256_mul_ps (lane, _mm256_set1_ps (dx.x ()));
  const __m256 ly = _mm256_mul_ps (lane, _mm256_set1_ps (dx.y ()));
  const __m256 lz = _mm256_mul_ps (lane, _mm256_set1_ps (dx.z ()));

  alignas (32) std::uint32_t seen_pixel[8];
  alignas (32) float seen_gap[8];
  alignas (32) float seen_sdf[8];

  for (int z = 0; z < kBlockSide; ++z)
    for (int y = 0; y < kBlockSide; ++y)
    {
      const Eigen::Vector3f row = origin + dy * static_cast<float> (y) + dz * static_cast<float> (z);
      const __m256 px = _mm256_add_ps (_mm256_set1_ps (row.x ()), lx);
      const __m256 py = _mm256_add_ps (_mm256_set1_ps (row.y ()), ly);
      const __m256 pz = _mm256_add_ps (_mm256_set1_ps (row.z ()), lz);
      if (_mm256_movemask_ps (_mm256_cmp_ps (pz, zero, _CMP_GT_OQ)) == 0)
        continue;
      __m256 uf, vf;
      __m256i u, v;
      const __m256 seen = avx2::projectToPixel8 (px, py, pz, f.camera, uf, vf, u, v);
      if (_mm256_movemask_ps (seen) == 0)
        continue;
      __m256 nearest, nearest_ok;
      const __m256 depth = sampleDepth8 (f, seen, uf, vf, u, v, nearest, nearest_ok);
      if (_mm256_movemask_ps (nearest_ok) == 0)
        continue;

      const __m256 sdf = _mm256_sub_ps (depth, pz);
      const __m256 update = _mm256_and_ps (nearest_ok, _mm256_cmp_ps (sdf, neg_truncation, _CMP_GE_OQ));
      int mask = _mm256_movemask_ps (update);
      if (mask == 0)
        continue;
      const __m256 tsdf = _mm256_min_ps (_mm256_div_ps (sdf, truncation), one);  // min(1, x) as std::min

      // The row's eight voxels (96 contiguous bytes) in three loads, deinterleaved into
      // sdf, weight and colour word. Gathering the three fields instead (24 loads) and
      // writing updated voxels field by field were a third of the kernel's time (AMD's
      // gathers issue a load per lane).
      TsdfVoxel* voxels = &block.voxels[static_cast<std::size_t> (localVoxelIndex (0, y, z))];
      float* voxel_floats_base = reinterpret_cast<float*> (voxels);
      __m256 w, old_sdf, word_f;
      loadVoxels8 (voxel_floats_base, old_sdf, w, word_f);
      const __m256i word = _mm256_castps_si256 (word_f);
      const __m256 w_new = _mm256_add_ps (w, one);
      const __m256 sdf_out = _mm256_div_ps (_mm256_add_ps (_mm256_mul_ps (w, old_sdf), tsdf), w_new);
      const __m256 weight_out = _mm256_min_ps (w_new, max_weight);

      // Distance layer: weight > 0 now, so clamp, scale and round half away from zero.
      const __m256 s = _mm256_mul_ps (_mm256_max_ps (_mm256_min_ps (sdf_out, one), _mm256_set1_ps (-1.f)),
                                      _mm256_set1_ps (kDistanceScale));
      const __m256 rounded = _mm256_blendv_ps (_mm256_sub_ps (s, half), _mm256_add_ps (s, half),
                                               _mm256_cmp_ps (s, zero, _CMP_GE_OQ));
      const __m256i new_distance = _mm256_cvttps_epi32 (rounded);

      __m256i word_out = word;
      if (f.color != nullptr)
      {
        word_out = fuseColor8 (f, update, u, v, word, w, w_new);
      }
      // Lanes not updated keep what was loaded; all eight voxels are stored back.
      storeVoxels8 (voxel_floats_base, _mm256_blendv_ps (old_sdf, sdf_out, update), _mm256_blendv_ps (w, weight_out, update),
                    _mm256_blendv_ps (word_f, _mm256_castsi256_ps (word_out), update));
      // The row's eight distances; the ninth, the apron's, is not touched (see
      // TSDFVolume::integrate).
      std::int16_t* distances = &block.distances[static_cast<std::size_t> (distanceIndex (0, y, z))];
      const __m128i old_distances = _mm_loadu_si128 (reinterpret_cast<const __m128i*> (distances));
      const __m128i packed = _mm256_castsi256_si128 (_mm256_permute4x64_epi64 (
          _mm256_packs_epi32 (new_distance, new_distance), _MM_SHUFFLE (3, 1, 2, 0)));
      const __m128i update16 = _mm256_castsi256_si128 (_mm256_permute4x64_epi64 (
          _mm256_packs_epi32 (_mm256_castps_si256 (update), _mm256_castps_si256 (update)), _MM_SHUFFLE (3, 1, 2, 0)));
      _mm_storeu_si128 (reinterpret_cast<__m128i*> (distances), _mm_blendv_epi8 (old_distances, packed, update16));

      if (observed != nullptr)
      {
        const __m256 abs_mask = _mm256_castsi256_ps (_mm256_set1_epi32 (0x7fffffff));
        const __m256 gap = _mm256_and_ps (_mm256_sub_ps (pz, nearest), abs_mask);
        const __m256 in_band = _mm256_and_ps (update, _mm256_and_ps (_mm256_cmp_ps (gap, truncation, _CMP_LT_OQ),
                                                                      _mm256_cmp_ps (_mm256_and_ps (sdf_out, abs_mask), one, _CMP_LT_OQ)));
        int seen_mask = _mm256_movemask_ps (in_band);
        if (seen_mask != 0)
        {
          _mm256_store_ps (seen_gap, gap);
          _mm256_store_ps (seen_sdf, sdf_out);
          _mm256_store_si256 (reinterpret_cast<__m256i*> (seen_pixel), _mm256_or_si256 (_mm256_slli_epi32 (v, 16), u));
          const std::uint32_t row_voxel = first_voxel + static_cast<std::uint32_t> (localVoxelIndex (0, y, z));
          for (; seen_mask != 0; seen_mask &= seen_mask - 1)
          {
            const int i = __builtin_ctz (static_cast<unsigned> (seen_mask));
            observed->push_back ({row_voxel + static_cast<std::uint32_t> (i), seen_pixel[i], seen_gap[i], seen_sdf[i]});
          }
        }
      }
    }
}
#else
void
integrateBlockAvx2 (VoxelBlock& block, const IntegrationFrame& frame, std::uint32_t first_voxel,
                    std::vector<SurfaceObservation>* observed)
{
  integrateBlockScalar (block, frame, first_voxel, observed);
}
#endif
}  // namespace detail
}  // namespace reconstruction
}  // namespace cuefusion
