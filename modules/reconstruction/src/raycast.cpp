// SPDX-License-Identifier: BSD-3-Clause
// TSDFVolume::raycast (§4.1.5): the model seen from a pose, ray by ray. One raycast builds
// the depth range of the allocated blocks per 8×8 tile (blockRanges), then casts the rows
// in parallel (RowCaster): with a depth hint, groups of eight rays first try Newton steps
// near the hint in AVX2 (refineNearHint8); every other ray goes through one per-pixel
// strategy chooser (RowCaster::castPixel: Newton near the hint, a short march around it, a
// march from the row's last surface behind a hole, a skipped hole, or a full march through
// the tile's range).
#include "voxel_access.h"

#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** Newton near a depth hint (refineNearHint and its eight-lane form): a field value of at
  * least this (in truncation units) is truncated, no surface close by ... */
constexpr float kNewtonTruncated = 0.9f;
/** ... and a step shorter than this (voxels) has settled: the last is taken unread. */
constexpr float kNewtonSettledVoxels = 0.25f;

/** \brief Conservative depth range of a block seen from a camera, per 8×8 pixel tile. */
struct RangeTiles
{
  static constexpr int kTile = 8;
  int cols = 0, rows = 0;
  std::vector<float> zmin, zmax;

  void
  reset (int width, int height)
  {
    cols = (width + kTile - 1) / kTile;
    rows = (height + kTile - 1) / kTile;
    zmin.assign (static_cast<std::size_t> (cols * rows), std::numeric_limits<float>::infinity ());
    zmax.assign (static_cast<std::size_t> (cols * rows), 0.f);
  }

  void
  merge (const RangeTiles& other)
  {
    for (std::size_t i = 0; i < zmin.size (); ++i)
    {
      zmin[i] = std::min (zmin[i], other.zmin[i]);
      zmax[i] = std::max (zmax[i], other.zmax[i]);
    }
  }

  void
  add (int c0, int r0, int c1, int r1, float lo, float hi)
  {
    for (int r = std::max (r0, 0); r <= std::min (r1, rows - 1); ++r)
      for (int c = std::max (c0, 0); c <= std::min (c1, cols - 1); ++c)
      {
        const std::size_t i = static_cast<std::size_t> (r * cols + c);
        zmin[i] = std::min (zmin[i], lo);
        zmax[i] = std::max (zmax[i], hi);
      }
  }
};

/** \brief Projects the eight corners of a block into tile coordinates. False when it is
  * wholly behind the camera or outside the image.
  */
inline bool
blockFootprint (const Eigen::Vector3f& corner0, const Eigen::Matrix3f& R_cw_scaled, const PinholeCamera& camera,
                float near, int& c0, int& r0, int& c1, int& r1, float& lo, float& hi)
{
  // Cheap rejection of blocks wholly behind the camera (most of a room, seen from inside).
  const Eigen::Vector3f center = corner0 + 0.5f * R_cw_scaled.rowwise ().sum ();
  if (center.z () + 0.87f * R_cw_scaled.col (0).norm () < near)
    return false;
  const float fx = static_cast<float> (camera.fx), fy = static_cast<float> (camera.fy);
  const float cx = static_cast<float> (camera.cx), cy = static_cast<float> (camera.cy);
  float umin = std::numeric_limits<float>::infinity (), vmin = umin, umax = -umin, vmax = -umin;
  lo = std::numeric_limits<float>::infinity ();
  hi = -lo;
  bool clipped = false;
  for (int i = 0; i < 8; ++i)
  {
    const Eigen::Vector3f p = corner0 + R_cw_scaled.col (0) * static_cast<float> (i & 1) +
                              R_cw_scaled.col (1) * static_cast<float> ((i >> 1) & 1) +
                              R_cw_scaled.col (2) * static_cast<float> ((i >> 2) & 1);
    lo = std::min (lo, p.z ());
    hi = std::max (hi, p.z ());
    if (p.z () < near)
    {
      clipped = true;
      continue;
    }
    const float inv_z = 1.f / p.z ();
    const float u = fx * p.x () * inv_z + cx, v = fy * p.y () * inv_z + cy;
    umin = std::min (umin, u);
    umax = std::max (umax, u);
    vmin = std::min (vmin, v);
    vmax = std::max (vmax, v);
  }
  if (hi < near)
    return false;
  lo = std::max (lo, near);
  if (clipped)  // straddles the near plane: may cover anything
  {
    umin = vmin = -1.f;
    umax = static_cast<float> (camera.width);
    vmax = static_cast<float> (camera.height);
  }
  if (umax < -0.5f || vmax < -0.5f || umin > camera.width - 0.5f || vmin > camera.height - 0.5f)
    return false;
  const float inv_tile = 1.f / static_cast<float> (RangeTiles::kTile);
  c0 = fastFloor ((std::max (umin, -1.f) + 0.5f) * inv_tile);
  r0 = fastFloor ((std::max (vmin, -1.f) + 0.5f) * inv_tile);
  c1 = fastFloor ((std::min (umax, static_cast<float> (camera.width)) + 0.5f) * inv_tile);
  r1 = fastFloor ((std::min (vmax, static_cast<float> (camera.height)) + 0.5f) * inv_tile);
  return true;
}

/** \brief Distance (in ray parameter) from \a g to where the ray leaves block \a block
  * (which holds it); \a g in voxel units, \a inverse_dir = 1 / the ray's direction in
  * voxel units (infinite along axes it does not move on).
  */
inline float
blockExit (const Eigen::Vector3f& g, const Eigen::Vector3i& block, const Eigen::Vector3f& inverse_dir)
{
  float t = std::numeric_limits<float>::infinity ();
  for (int a = 0; a < 3; ++a)
  {
    if (std::isinf (inverse_dir[a]))
      continue;
    const float lower = static_cast<float> (block[a] * kBlockSide);
    const float face = inverse_dir[a] > 0.f ? lower + kBlockSide : lower;
    t = std::min (t, (face - g[a]) * inverse_dir[a]);
  }
  return t;
}

/** \brief The voxel nearest a ray's hit: its colour is read after the row, its number goes
  * to RaycastResult::voxels. */
struct VoxelHit
{
  const TsdfVoxel* voxel = nullptr;
  VoxelNumber number = kNoVoxel;
};

/** \brief Marches one ray (§4.1.5). \a origin and \a dir are in voxel units, \a dir the
  * camera-frame ray with z = 1 turned into the world, so the ray parameter is the
  * z-depth. Returns the depth of the first front-facing zero crossing (0 for none), the
  * voxel nearest to it in \a hit and the field's gradient there in \a gradient (zero
  * when unknown). With \a started_behind given, a first band sample behind a surface
  * stops the march and sets it (the start was too deep; the caller starts earlier).
  *
  * Outside the truncation band the ray moves by blocks (unallocated) or by the band's
  * depth (truncated voxels); inside it by the interpolated distance, so the last two
  * samples bracket the crossing on the interpolated field itself.
  */
inline float
castRay (detail::VoxelAccessor& access, const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float z_start,
         float z_end, float truncation_voxels, VoxelHit* hit, Eigen::Vector3f* gradient,
         bool* started_behind = nullptr)
{
  const float one_voxel = 1.f / dir.norm ();
  const Eigen::Vector3f inverse_dir = dir.cwiseInverse ();  // divisions once per ray, not per block
  float z = z_start, z_prev = 0.f, f_prev = 0.f;
  bool in_front = false;  // the previous sample was a valid positive one
  bool sampled = false;   // a sample inside the band has been seen
  while (z < z_end)
  {
    const Eigen::Vector3f g = origin + dir * z;
    const Eigen::Vector3i lower = fastFloor (g);
    const Eigen::Vector3i block_index = blockOfVoxel (lower);
    const VoxelBlock* block = access.block (block_index);
    if (block == nullptr)
    {
      // Unallocated block: empty space; jump to just past the block's far side.
      in_front = false;
      z += std::max (blockExit (g, block_index, inverse_dir), 0.f) + 0.1f * one_voxel;
      continue;
    }
    // The nearest voxel: in the block just found or its apron.
    const Eigen::Vector3i local =
        lower - block_index * kBlockSide +
        (g - lower.cast<float> ()).unaryExpr ([] (float t) { return t >= 0.5f ? 1.f : 0.f; }).cast<int> ();
    const std::int16_t* nearest = &block->distances[static_cast<std::size_t> (distanceIndex (local.x (), local.y (), local.z ()))];
    if (*nearest == kUnobservedDistance || *nearest >= static_cast<std::int16_t> (kDistanceScale))
    {
      // Truncated or never observed: at least a band's depth in front of any surface seen
      // from this side, since the rays that saw a surface also observed the band in front
      // of it, which is τ deep along the normal and deeper along an oblique ray. Stepping
      // τ − 1 voxels lands in that band at the latest. (Unobserved voxels are mostly
      // space no ray reached inside a block allocated for a nearby surface; stepping
      // them one voxel at a time was most of the full marches' time on 7-Scenes.)
      in_front = false;
      z += (truncation_voxels - 1.f) * one_voxel;
      continue;
    }
    float f;
    if (!access.interpolate (g, f))
      f = decodeDistance (*nearest);
    if (f <= 0.f)
    {
      if (in_front)
      {
        float z_hit = z_prev + (z - z_prev) * zeroCrossing (f_prev, f);
        // One secant step on the bracket side the estimate falls on; the same cell gives
        // the gradient, i.e. the normal.
        float f_hit;
        if (access.interpolate (origin + dir * z_hit, f_hit, *gradient))
        {
          if (std::abs (f_hit) > 1e-3f)
            z_hit = f_hit > 0.f ? z_hit + (z - z_hit) * zeroCrossing (f_hit, f)
                                : z_prev + (z_hit - z_prev) * zeroCrossing (f_prev, f_hit);
        }
        else
          gradient->setZero ();
        hit->voxel = access.get (nearestVoxel (origin + dir * z_hit), hit->number);
        if (hit->voxel == nullptr)
          hit->voxel = access.get (nearestVoxel (g), hit->number);
        return z_hit;
      }
      if (started_behind != nullptr && !sampled)
      {
        *started_behind = true;  // the start lies behind a surface: the caller restarts
        return 0.f;
      }
      sampled = true;
      in_front = false;  // behind a surface (or a back face): keep looking
      z += one_voxel;
      continue;
    }
    in_front = true;
    sampled = true;
    z_prev = z;
    f_prev = f;
    z += std::max (1.f, 0.9f * f * truncation_voxels) * one_voxel;
  }
  return 0.f;
}

/** \brief How far along the ray (voxels) Newton from a hint at depth \a z may settle: a band
  * plus three σ of the depth noise at \a z, the window the march after a failed Newton
  * searches too (from a band plus 3σ in front of the depth to a band plus 3σ behind it).
  * Far from the camera, where the noise is centimetres, a fixed band made Newton give up
  * on rays its steps were converging on, and their marches found the same surface.
  */
inline float
newtonReach (float z, float truncation_voxels, float inv_voxel)
{
  return truncation_voxels + 3.f * KinectNoiseModel::atNormalIncidence (z) * inv_voxel;
}

/** \brief With a depth hint (the frame just fused at this pose), the surface lies within a
  * voxel or two of the hint along the ray: Newton steps on the trilinear field from there
  * (each step one cell read, whose gradient also gives the slope and the normal) replace
  * the march's 3–4 samples and bracket search. Returns 0 — the caller then marches —
  * when a cell is unobserved, the field is truncated or back-facing there (slope ≥ 0),
  * the steps go further from the hint than newtonReach, or they do not settle within
  * four steps.
  */
inline float
refineNearHint (detail::VoxelAccessor& access, const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float z_hint,
                float truncation_voxels, float inv_voxel, VoxelHit* hit, Eigen::Vector3f* gradient)
{
  const float voxels_per_z = dir.norm ();
  const float reach = newtonReach (z_hint, truncation_voxels, inv_voxel);
  float z = z_hint;
  for (int step = 0; step < 4; ++step)
  {
    float f;
    if (!access.interpolate (origin + dir * z, f, *gradient))
      return 0.f;
    if (!(std::abs (f) < kNewtonTruncated))
      return 0.f;  // truncated: no surface close by
    const float slope = gradient->dot (dir);  // truncation units per unit of z
    if (!(slope < 0.f))
      return 0.f;  // the field does not fall along the ray: a back face or a corner
    const float dz = -f / slope;
    z += dz;
    if (std::abs (z - z_hint) * voxels_per_z > reach)
      return 0.f;  // wandered off to another surface
    // Along a ray the trilinear field is a cubic with small higher terms: from within a
    // quarter voxel one Newton step lands within a few hundredths of a voxel (0.1 mm at
    // 1 cm voxels), so the step is taken without reading the cell again.
    if (std::abs (dz) * voxels_per_z < kNewtonSettledVoxels)
    {
      hit->voxel = access.get (nearestVoxel (origin + dir * z), hit->number);
      return hit->voxel != nullptr ? z : 0.f;
    }
  }
  return 0.f;
}
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
// blend, trilinearBlend and trilinearGradient (voxel.h) are instantiated below for eight
// lanes in a file compiled without AVX; GCC notes (at the end of the file, hence no pop)
// that passing such values by value would change the ABI. They are always inlined into
// the AVX2 functions, so no call ever passes one.
#pragma GCC diagnostic ignored "-Wpsabi"
/** \brief refineNearHint for eight rays at once (lanes whose bit is set in \a lanes):
  * the cells are read per lane, the trilinear value, gradient and Newton step are computed
  * for all eight in AVX2. On return z[i] > 0 and grad[3][i] for the rays that settled,
  * z[i] = 0 for the rest (the caller falls back to the scalar path and the march for
  * those); writeSettledRays8 turns the settled ones into the outputs.
  * Measured on icl-livingroom1: raycast 15.3–17.2 → 13.7–14.3 ms a frame (A/B, three
  * rounds). Tried and slower here (AMD Zen 4, cuefusion_bench_raycast): prefetching the
  * cells a pass or a row ahead, and AVX2 gathers of the corners (per corner, or per
  * x-pair of corners, and per block): the gathers cost a load per lane and more than the
  * per-lane reads they replace.
  */
CUEFUSION_AVX2 void
refineNearHint8 (detail::VoxelAccessor& access, const Eigen::Vector3f& origin, const float* dir_x, const float* dir_y,
                 const float* dir_z, const float* hint, int lanes, float truncation_voxels, float inv_voxel, float* z_out,
                 float* grad_out)
{
  const __m256 dx = _mm256_loadu_ps (dir_x), dy = _mm256_loadu_ps (dir_y), dz = _mm256_loadu_ps (dir_z);
  const __m256 ox = _mm256_set1_ps (origin.x ()), oy = _mm256_set1_ps (origin.y ()), oz = _mm256_set1_ps (origin.z ());
  const __m256 z_hint = _mm256_loadu_ps (hint);
  const __m256 voxels_per_z = _mm256_sqrt_ps (_mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (dx, dx), _mm256_mul_ps (dy, dy)),
                                                             _mm256_mul_ps (dz, dz)));
  const __m256 zero = _mm256_setzero_ps (), scale = _mm256_set1_ps (1.f / kDistanceScale);
  // newtonReach per lane, in the same float operations.
  const __m256 reach = _mm256_add_ps (
      _mm256_set1_ps (truncation_voxels),
      _mm256_mul_ps (_mm256_mul_ps (_mm256_set1_ps (3.f), avx2::kinectNoiseAtNormalIncidence (z_hint)), _mm256_set1_ps (inv_voxel)));
  __m256 z = z_hint, z_result = zero, gx_result = zero, gy_result = zero, gz_result = zero;
  alignas (32) std::int32_t block_x[8], block_y[8], block_z[8];
  // The cells' corners as read: pairs[p][i] holds lane i's x-pair p (corners 2p and 2p + 1,
  // two int16 distances); lanes not read keep zeros (masked out below).
  alignas (32) std::uint32_t pairs[4][8] = {};
  int active = lanes;
  __m256i cell_x = _mm256_undefined_si256 (), cell_y = cell_x, cell_z = cell_x;
  for (int step = 0; step < 4 && active != 0; ++step)
  {
    const __m256 gx = _mm256_add_ps (ox, _mm256_mul_ps (dx, z));
    const __m256 gy = _mm256_add_ps (oy, _mm256_mul_ps (dy, z));
    const __m256 gz = _mm256_add_ps (oz, _mm256_mul_ps (dz, z));
    const __m256 flx = _mm256_floor_ps (gx), fly = _mm256_floor_ps (gy), flz = _mm256_floor_ps (gz);
    const __m256i next_x = _mm256_cvttps_epi32 (flx), next_y = _mm256_cvttps_epi32 (fly), next_z = _mm256_cvttps_epi32 (flz);
    // A step that stays in the cell just read needs no read: the trilinear field there is
    // that cell's, and the lanes still active all read theirs successfully (a quarter of
    // the second steps on 7-Scenes).
    int to_read = active;
    if (step > 0)
    {
      const __m256i same = _mm256_and_si256 (_mm256_and_si256 (_mm256_cmpeq_epi32 (next_x, cell_x), _mm256_cmpeq_epi32 (next_y, cell_y)),
                                             _mm256_cmpeq_epi32 (next_z, cell_z));
      to_read &= ~_mm256_movemask_ps (_mm256_castsi256_ps (same));
    }
    cell_x = next_x;
    cell_y = next_y;
    cell_z = next_z;
    // Per lane its cell's block (voxel index / 8) and the lower corner's place in that
    // block's distance layer, computed for all lanes at once.
    const __m256i last = _mm256_set1_epi32 (kBlockSide - 1), side = _mm256_set1_epi32 (kDistanceSide);
    _mm256_store_si256 (reinterpret_cast<__m256i*> (block_x), _mm256_srai_epi32 (next_x, 3));
    _mm256_store_si256 (reinterpret_cast<__m256i*> (block_y), _mm256_srai_epi32 (next_y, 3));
    _mm256_store_si256 (reinterpret_cast<__m256i*> (block_z), _mm256_srai_epi32 (next_z, 3));
    static_assert (kBlockSide == 8, "the block index is the voxel index shifted by 3");
    alignas (32) std::int32_t layer_index[8];
    _mm256_store_si256 (reinterpret_cast<__m256i*> (layer_index),
                        _mm256_add_epi32 (_mm256_and_si256 (next_x, last),
                                          _mm256_mullo_epi32 (side, _mm256_add_epi32 (_mm256_and_si256 (next_y, last),
                                                                                      _mm256_mullo_epi32 (side, _mm256_and_si256 (next_z, last))))));
    int read = active;
    for (int m = to_read; m != 0; m &= m - 1)
    {
      const int i = __builtin_ctz (static_cast<unsigned> (m));
      // The cell's four x-pairs, copied as they are into the lane's column (through
      // VoxelAccessor::cell and a copy it took ~100 instructions a lane; converting each
      // corner to float here, 8 scalar conversions a lane, was a tenth of this function).
      const VoxelBlock* block = access.block (Eigen::Vector3i (block_x[i], block_y[i], block_z[i]));
      if (block == nullptr)
      {
        read &= ~(1 << i);
        continue;
      }
      const std::int16_t* base = block->distances.data () + layer_index[i];
      constexpr int dy = kDistanceSide, dz = kDistanceSide * kDistanceSide;
      std::memcpy (&pairs[0][i], base, sizeof (std::uint32_t));
      std::memcpy (&pairs[1][i], base + dy, sizeof (std::uint32_t));
      std::memcpy (&pairs[2][i], base + dz, sizeof (std::uint32_t));
      std::memcpy (&pairs[3][i], base + dz + dy, sizeof (std::uint32_t));
    }
    // All lanes at once: the pairs' halves sign-extended and converted (corner 2p is the
    // low half: little-endian), and lanes with an unobserved corner dropped.
    __m256 v[8];
    __m256i unobserved = _mm256_setzero_si256 ();
    const __m256i marker = _mm256_set1_epi32 (kUnobservedDistance);
    for (int p = 0; p < 4; ++p)
    {
      const __m256i pair = _mm256_load_si256 (reinterpret_cast<const __m256i*> (pairs[p]));
      const __m256i low = _mm256_srai_epi32 (_mm256_slli_epi32 (pair, 16), 16), high = _mm256_srai_epi32 (pair, 16);
      unobserved = _mm256_or_si256 (unobserved, _mm256_or_si256 (_mm256_cmpeq_epi32 (low, marker), _mm256_cmpeq_epi32 (high, marker)));
      v[2 * p] = _mm256_cvtepi32_ps (low);
      v[2 * p + 1] = _mm256_cvtepi32_ps (high);
    }
    read &= ~_mm256_movemask_ps (_mm256_castsi256_ps (unobserved));
    const __m256 fx = _mm256_sub_ps (gx, flx), fy = _mm256_sub_ps (gy, fly), fz = _mm256_sub_ps (gz, flz);
    // The scalar path's formulas (voxel.h, VoxelAccessor::interpolate), eight lanes at once.
    const __m256 f = _mm256_mul_ps (trilinearBlend (v, fx, fy, fz), scale);
    __m256 grad_x, grad_y, grad_z;
    trilinearGradient (v, fx, fy, fz, grad_x, grad_y, grad_z);
    grad_x = _mm256_mul_ps (grad_x, scale);
    grad_y = _mm256_mul_ps (grad_y, scale);
    grad_z = _mm256_mul_ps (grad_z, scale);
    const __m256i bits = _mm256_setr_epi32 (1, 2, 4, 8, 16, 32, 64, 128);
    __m256 ok = _mm256_castsi256_ps (
        _mm256_cmpeq_epi32 (_mm256_and_si256 (_mm256_set1_epi32 (read), bits), bits));
    ok = _mm256_and_ps (ok, _mm256_cmp_ps (avx2::abs (f), _mm256_set1_ps (kNewtonTruncated), _CMP_LT_OQ));  // else truncated
    const __m256 slope = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (grad_x, dx), _mm256_mul_ps (grad_y, dy)),
                                        _mm256_mul_ps (grad_z, dz));
    ok = _mm256_and_ps (ok, _mm256_cmp_ps (slope, zero, _CMP_LT_OQ));  // else back face or corner
    const __m256 step_z = _mm256_div_ps (_mm256_sub_ps (zero, f), slope);
    const __m256 z_next = _mm256_add_ps (z, step_z);
    ok = _mm256_and_ps (ok, _mm256_cmp_ps (_mm256_mul_ps (avx2::abs (_mm256_sub_ps (z_next, z_hint)), voxels_per_z),
                                           reach, _CMP_LE_OQ));  // else wandered off
    const __m256 settled = _mm256_and_ps (
        ok, _mm256_cmp_ps (_mm256_mul_ps (avx2::abs (step_z), voxels_per_z), _mm256_set1_ps (kNewtonSettledVoxels), _CMP_LT_OQ));
    z_result = _mm256_blendv_ps (z_result, z_next, settled);
    gx_result = _mm256_blendv_ps (gx_result, grad_x, settled);
    gy_result = _mm256_blendv_ps (gy_result, grad_y, settled);
    gz_result = _mm256_blendv_ps (gz_result, grad_z, settled);
    active = _mm256_movemask_ps (_mm256_andnot_ps (settled, ok));
    z = z_next;
  }
  _mm256_storeu_ps (z_out, z_result);
  _mm256_storeu_ps (grad_out, gx_result);
  _mm256_storeu_ps (grad_out + 8, gy_result);
  _mm256_storeu_ps (grad_out + 16, gz_result);
}

/** \brief The per-pixel outputs of eight rays that refineNearHint8 settled (z[i] > 0), as the
  * scalar loop writes them: the vertex (camera ray · z), the normal (the gradient turned
  * into the camera and normalised, facing the camera) and the voxel nearest the hit, whose
  * colour and number are written after the row. A lane whose nearest voxel is unallocated gets
  * z[i] = 0 (the scalar path then marches). Returns the lanes written.
  *
  * The same work per pixel in the scalar loop (three divisions for the normal, a voxel
  * lookup) was a tenth of the whole run's time on icl-livingroom1.
  */
CUEFUSION_AVX2 int
writeSettledRays8 (detail::VoxelAccessor& access, const Eigen::Vector3f& origin, const float* dir_x, const float* dir_y,
                   const float* dir_z, const float* ray_x, float ray_y, const Eigen::Matrix3f& R_cw, float* z,
                   const float* grad, float* vertices, float* normals, VoxelHit* hits)
{
  const __m256 zero = _mm256_setzero_ps ();
  const __m256 depth = _mm256_loadu_ps (z);
  int settled = _mm256_movemask_ps (_mm256_cmp_ps (depth, zero, _CMP_GT_OQ));
  if (settled == 0)
    return 0;
  // Nearest voxels: ⌊origin + dir · z + ½⌋, as nearestVoxel ().
  const __m256 half = _mm256_set1_ps (0.5f);
  alignas (32) std::int32_t nx[8], ny[8], nz[8];
  _mm256_store_si256 (reinterpret_cast<__m256i*> (nx), _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (
      _mm256_add_ps (_mm256_set1_ps (origin.x ()), _mm256_mul_ps (_mm256_loadu_ps (dir_x), depth)), half))));
  _mm256_store_si256 (reinterpret_cast<__m256i*> (ny), _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (
      _mm256_add_ps (_mm256_set1_ps (origin.y ()), _mm256_mul_ps (_mm256_loadu_ps (dir_y), depth)), half))));
  _mm256_store_si256 (reinterpret_cast<__m256i*> (nz), _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (
      _mm256_add_ps (_mm256_set1_ps (origin.z ()), _mm256_mul_ps (_mm256_loadu_ps (dir_z), depth)), half))));
  for (int m = settled; m != 0; m &= m - 1)
  {
    const int i = __builtin_ctz (static_cast<unsigned> (m));
    VoxelNumber number;
    const TsdfVoxel* hit = access.get (Eigen::Vector3i (nx[i], ny[i], nz[i]), number);
    if (hit == nullptr)
    {
      settled &= ~(1 << i);
      z[i] = 0.f;
      continue;
    }
    __builtin_prefetch (hit);
    hits[i] = {hit, number};
  }
  const __m256 keep = _mm256_castsi256_ps (_mm256_cmpeq_epi32 (
      _mm256_and_si256 (_mm256_set1_epi32 (settled), _mm256_setr_epi32 (1, 2, 4, 8, 16, 32, 64, 128)),
      _mm256_setr_epi32 (1, 2, 4, 8, 16, 32, 64, 128)));
  const __m256 nan = _mm256_set1_ps (std::numeric_limits<float>::quiet_NaN ());
  const __m256 px = _mm256_mul_ps (_mm256_loadu_ps (ray_x), depth), py = _mm256_mul_ps (_mm256_set1_ps (ray_y), depth);
  const __m256 gx = _mm256_loadu_ps (grad), gy = _mm256_loadu_ps (grad + 8), gz = _mm256_loadu_ps (grad + 16);
  __m256 n[3];
  for (int r = 0; r < 3; ++r)
    n[r] = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (_mm256_set1_ps (R_cw (r, 0)), gx), _mm256_mul_ps (_mm256_set1_ps (R_cw (r, 1)), gy)),
                          _mm256_mul_ps (_mm256_set1_ps (R_cw (r, 2)), gz));
  const __m256 norm = _mm256_sqrt_ps (
      _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (n[0], n[0]), _mm256_mul_ps (n[1], n[1])), _mm256_mul_ps (n[2], n[2])));
  // Facing the camera: n · p ≤ 0, else flipped (the sign folded into the normalisation).
  const __m256 facing = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (n[0], px), _mm256_mul_ps (n[1], py)), _mm256_mul_ps (n[2], depth));
  const __m256 scale = _mm256_blendv_ps (_mm256_div_ps (_mm256_set1_ps (1.f), norm), _mm256_div_ps (_mm256_set1_ps (-1.f), norm),
                                         _mm256_cmp_ps (facing, zero, _CMP_GT_OQ));
  avx2::storeXyz8 (vertices, _mm256_blendv_ps (nan, px, keep), _mm256_blendv_ps (nan, py, keep), _mm256_blendv_ps (nan, depth, keep));
  avx2::storeXyz8 (normals, _mm256_blendv_ps (nan, _mm256_mul_ps (n[0], scale), keep),
                   _mm256_blendv_ps (nan, _mm256_mul_ps (n[1], scale), keep), _mm256_blendv_ps (nan, _mm256_mul_ps (n[2], scale), keep));
  return settled;
}
#endif

/** \brief The depth range of the allocated blocks per tile: rays start at the nearest
  * block of their tile instead of at the camera, and stop behind the farthest. */
RangeTiles
blockRanges (const std::vector<Eigen::Vector3i>& block_indices, const PinholeCamera& camera, const Eigen::Isometry3f& world_to_camera,
             float block_size, float near)
{
  const Eigen::Matrix3f R_cw_block = world_to_camera.linear () * block_size;
  RangeTiles tiles;
  tiles.reset (camera.width, camera.height);
  const int block_count = static_cast<int> (block_indices.size ());
  std::mutex tiles_mutex;
  parallelForChunks (block_count, 1024, [&] (int, int begin, int end) {
    RangeTiles mine;
    mine.reset (camera.width, camera.height);
    for (int i = begin; i < end; ++i)
    {
      const Eigen::Vector3f corner0 = world_to_camera * (block_indices[static_cast<std::size_t> (i)].cast<float> () * block_size);
      int c0, r0, c1, r1;
      float lo, hi;
      if (blockFootprint (corner0, R_cw_block, camera, near, c0, r0, c1, r1, lo, hi))
        mine.add (c0, r0, c1, r1, lo, hi);
    }
    const std::lock_guard<std::mutex> lock (tiles_mutex);  // min/max: the merge order does not matter
    tiles.merge (mine);
  });
  return tiles;
}

/** \brief What every ray of one raycast shares. */
struct RayFrame
{
  const PinholeCamera& camera;
  const cv::Mat& depth_hint;
  const RaycastHoleSkip& skip;
  bool skip_holes;
  const RangeTiles& tiles;
  Eigen::Matrix3f R, R_cw;             ///< camera-to-world rotation and its inverse
  Eigen::Vector3f origin_voxels;       ///< the camera centre in voxel units
  float inv_voxel, truncation_voxels;
  float hint_margin, truncation;       ///< metres
  float inv_fx, inv_fy, cx, cy;        ///< ray directions in float (PinholeCamera::backProject is double)
  bool use_avx2;
  const VoxelValueLayer* values;       ///< sampled into RaycastResult::values, or nullptr

  /** \brief Where the sampled layer keeps voxel \a n's value, or nullptr (reads as 0). */
  const std::uint32_t*
  valueOf (VoxelNumber n) const
  {
    const std::size_t id = n / kBlockVoxels;
    return n != kNoVoxel && id < values->blocks.size () && values->blocks[id] != nullptr
               ? values->blocks[id] + n % kBlockVoxels
               : nullptr;
  }
};

/** \brief Casts the rays of one row after another into \a out; its buffers are reused
  * from row to row (one per work item). */
class RowCaster
{
public:
  RowCaster (const TSDFVolume& volume, const RayFrame& f, RaycastResult& out);
  void castRow (int v);

private:
  /** Vertices and normals set to NaN for \a count pixels of row \a v from \a first. */
  void clearVertices (int v, int first, int count);
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
  /** Rays with a usable hint, eight at a time (hint_z_: > 0 settled and written, 0 failed,
    * < 0 not tried); what does not settle goes the scalar way. */
  void castHintedGroups (int v, float ray_y);
#endif
  /** The per-pixel strategy chooser: the depth of the surface ray \a u of row \a v meets
    * (0: none), with the voxel hit and the TSDF gradient there. \a skipped: a hole searched
    * before and not due again (RaycastHoleSkip). */
  float castPixel (int u, int v, std::size_t tile, float row_z, const std::uint8_t* skip_row, bool& skipped, VoxelHit* hit,
                   Eigen::Vector3f* grad);

  detail::VoxelAccessor access_;
  const RayFrame& f_;
  RaycastResult& out_;
  bool vector_hints_ = false;
  // The voxels hit on a row, read for colour after the row: the 12-byte voxels
  // are mostly out of cache by now (integration streamed tens of MB of them), and reading
  // each right after its ray was a fifth of the row loop's time waiting for memory.
  // Prefetched when found, they arrive while the next rays are cast.
  std::vector<VoxelHit> hits_;
  std::vector<float> hint_z_;                   ///< the eight-ray kernels' results
  std::vector<float> dirs_x_, dirs_y_, dirs_z_;  ///< the row's rays in the world, voxels per metre of z
  std::vector<float> ray_x_;                    ///< camera rays' x at z = 1
};

RowCaster::RowCaster (const TSDFVolume& volume, const RayFrame& f, RaycastResult& out)
  : access_ (volume)
  , f_ (f)
  , out_ (out)
  , hits_ (static_cast<std::size_t> (f.camera.width))
  , hint_z_ (static_cast<std::size_t> (f.camera.width))
  , dirs_x_ (static_cast<std::size_t> (f.camera.width))
  , dirs_y_ (dirs_x_.size ())
  , dirs_z_ (dirs_x_.size ())
  , ray_x_ (static_cast<std::size_t> (f.camera.width))
{
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
  vector_hints_ = f.use_avx2 && !f.depth_hint.empty ();
#endif
  for (int u = 0; u < f.camera.width; ++u)
    ray_x_[static_cast<std::size_t> (u)] = (static_cast<float> (u) - f.cx) * f.inv_fx;
}

void
RowCaster::clearVertices (int v, int first, int count)
{
  constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN ();
  std::fill (out_.vertices.ptr<float> (v) + 3 * first, out_.vertices.ptr<float> (v) + 3 * (first + count), kNaNf);
  std::fill (out_.normals.ptr<float> (v) + 3 * first, out_.normals.ptr<float> (v) + 3 * (first + count), kNaNf);
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
void
RowCaster::castHintedGroups (int v, float ray_y)
{
  const int width = f_.camera.width;
  const RangeTiles& tiles = f_.tiles;
  const float* hint_row = f_.depth_hint.ptr<float> (v);
  cv::Vec3f* vertex_row = out_.vertices.ptr<cv::Vec3f> (v);
  cv::Vec3f* normal_row = out_.normals.ptr<cv::Vec3f> (v);
  for (int u0 = 0; u0 + 8 <= width; u0 += 8)
  {
    const std::size_t tile = static_cast<std::size_t> ((v / RangeTiles::kTile) * tiles.cols + u0 / RangeTiles::kTile);
    static_assert (RangeTiles::kTile == 8, "eight rays share a tile");
    int lanes = 0;
    const float* dir_x = &dirs_x_[static_cast<std::size_t> (u0)];
    const float* dir_y = &dirs_y_[static_cast<std::size_t> (u0)];
    const float* dir_z = &dirs_z_[static_cast<std::size_t> (u0)];
    if (tiles.zmax[tile] > tiles.zmin[tile])
      for (int i = 0; i < 8; ++i)
      {
        const float d = hint_row[u0 + i];
        if (d > 0.f && std::isfinite (d) && d - f_.hint_margin > tiles.zmin[tile])
          lanes |= 1 << i;
      }
    if (lanes == 0)
    {
      std::fill (hint_z_.begin () + u0, hint_z_.begin () + u0 + 8, 0.f);
      clearVertices (v, u0, 8);
      continue;
    }
    alignas (32) float grads[24];
    float* z8 = &hint_z_[static_cast<std::size_t> (u0)];
    refineNearHint8 (access_, f_.origin_voxels, dir_x, dir_y, dir_z, hint_row + u0, lanes, f_.truncation_voxels, f_.inv_voxel, z8, grads);
    if (writeSettledRays8 (access_, f_.origin_voxels, dir_x, dir_y, dir_z, &ray_x_[static_cast<std::size_t> (u0)], ray_y, f_.R_cw, z8,
                           grads, &vertex_row[u0][0], &normal_row[u0][0], &hits_[static_cast<std::size_t> (u0)]) == 0)
      clearVertices (v, u0, 8);  // it writes nothing when no ray settled
    else if (f_.values != nullptr)
      for (int i = 0; i < 8; ++i)
        if (const std::uint32_t* value = f_.valueOf (hits_[static_cast<std::size_t> (u0 + i)].number))
          __builtin_prefetch (value);
  }
  for (int u = width - width % 8; u < width; ++u)
    hint_z_[static_cast<std::size_t> (u)] = -1.f;  // the row's tail: scalar
  clearVertices (v, width - width % 8, width % 8);
}
#endif

float
RowCaster::castPixel (int u, int v, std::size_t tile, float row_z, const std::uint8_t* skip_row, bool& skipped, VoxelHit* hit,
                      Eigen::Vector3f* grad)
{
  const RangeTiles& tiles = f_.tiles;
  const Eigen::Vector3f dir (dirs_x_[static_cast<std::size_t> (u)], dirs_y_[static_cast<std::size_t> (u)],
                             dirs_z_[static_cast<std::size_t> (u)]);
  const Eigen::Vector3f& origin_voxels = f_.origin_voxels;
  const float truncation_voxels = f_.truncation_voxels, hint_margin = f_.hint_margin, truncation = f_.truncation;
  float z = 0.f;
  bool hinted = false;
  if (!f_.depth_hint.empty ())
  {
    const float d = f_.depth_hint.at<float> (v, u);
    if (d > 0.f && std::isfinite (d) && d - hint_margin > tiles.zmin[tile])
    {
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
      if (vector_hints_ && hint_z_[static_cast<std::size_t> (u)] == 0.f)
        z = 0.f;  // the eight-ray Newton failed: march
      else
#endif
        z = refineNearHint (access_, origin_voxels, dir, d, truncation_voxels, f_.inv_voxel, hit, grad);
      hinted = z > 0.f;
    }
    if (!hinted && d > 0.f && std::isfinite (d) && d - hint_margin > tiles.zmin[tile])
    {
      // The surface lies near the depth just fused (within its noise), or the model
      // has none there: the march stops a band plus three noise σ behind it rather
      // than at the tile's farthest block (a surface further back would be hidden
      // behind what the frame measured). Saves a tenth of the raycast on 7-Scenes.
      bool behind = false;
      const float noise = 3.f * static_cast<float> (kinectAxialNoise (d, 0.0));
      const float z_end = std::min (tiles.zmax[tile], d + truncation + noise);
      z = castRay (access_, origin_voxels, dir, d - hint_margin, z_end, truncation_voxels, hit, grad, &behind);
      hinted = !behind;
      const float earlier = d - hint_margin - truncation - noise;
      if (behind && earlier > tiles.zmin[tile])
      {
        // The start lay behind the model's surface: the fused surface is in front of
        // the depth just measured (noise, an averaged edge). Try once from a band
        // plus three noise σ further in front before marching from the tile's
        // nearest block: a fifth of the failed-Newton rays start behind, and their
        // full marches were a tenth of the raycast on 7-Scenes. A second surface
        // still further in front is missed (the depth hint's trade again).
        behind = false;
        z = castRay (access_, origin_voxels, dir, earlier, z_end, truncation_voxels, hit, grad, &behind);
        hinted = !behind;
      }
    }
    else if (!hinted && !(d > 0.f) && row_z > 0.f && row_z - truncation > tiles.zmin[tile])
    {
      // A hole next to a surface just found on this row: most holes (dropouts on a
      // surface) see that surface, so first Newton from its depth.
      z = refineNearHint (access_, origin_voxels, dir, row_z, truncation_voxels, f_.inv_voxel, hit, grad);
      hinted = z > 0.f;
    }
    if (!hinted && !(d > 0.f))
    {
      // Behind a hole: the previous search from about here found nothing (see
      // RaycastHoleSkip) and this pixel is not among this call's re-searched ones.
      const RaycastHoleSkip& skip = f_.skip;
      if (skip_row != nullptr && skip_row[u] != 0 && (static_cast<unsigned> (u + v) + skip.phase) % skip.refresh_period != 0)
      {
        skipped = true;
        return 0.f;
      }
    }
    if (!hinted && !(d > 0.f) && row_z > 0.f && row_z - truncation > tiles.zmin[tile])
    {
      // A hole in the depth (shadow, dropout) next to a surface just found on this row:
      // march from a band in front of that surface instead of from the tile's nearest
      // block. On Kinect data holes are ~10 % of the pixels and full marches through
      // them were most of the raycast's time. A surface nearer than that start is
      // missed (the same trade as the depth hint's).
      bool behind = false;
      z = castRay (access_, origin_voxels, dir, row_z - truncation, tiles.zmax[tile], truncation_voxels, hit, grad, &behind);
      hinted = !behind;
    }
  }
  if (!hinted)
    z = castRay (access_, origin_voxels, dir, tiles.zmin[tile], tiles.zmax[tile], truncation_voxels, hit, grad);
  return z;
}

void
RowCaster::castRow (int v)
{
  const int width = f_.camera.width;
  const RangeTiles& tiles = f_.tiles;
  std::fill (hits_.begin (), hits_.end (), VoxelHit ());
  // Vertices and normals are cleared to NaN where nothing else writes them first: the
  // eight-ray kernel writes all eight pixels of each group it runs on, so with it only
  // the groups it skips are filled (clearing whole rows first wrote 7 MB a frame twice).
  // Colours and voxel numbers are written for every pixel after the row.
  if (!vector_hints_)
    clearVertices (v, 0, width);
  std::uint8_t* empty_row = f_.depth_hint.empty () ? nullptr : out_.empty_holes.ptr<std::uint8_t> (v);
  const std::uint8_t* skip_row = f_.skip_holes ? f_.skip.empty_holes.ptr<std::uint8_t> (v) : nullptr;
  if (empty_row != nullptr)
    std::fill (empty_row, empty_row + width, std::uint8_t{0});
  cv::Vec3f* vertex_row = out_.vertices.ptr<cv::Vec3f> (v);
  cv::Vec3f* normal_row = out_.normals.ptr<cv::Vec3f> (v);
  cv::Vec3b* color_row = out_.colors.ptr<cv::Vec3b> (v);
  std::int32_t* voxel_row = out_.voxels.ptr<std::int32_t> (v);
  float row_z = 0.f;  // depth of the last surface found on this row
  const float ray_y = (static_cast<float> (v) - f_.cy) * f_.inv_fy;
  // The row's rays in the world, in voxel units per metre of z-depth (read by the
  // eight-ray kernel and the per-pixel loop).
  // R · (x, y, 1) / voxel = x · R₀ / voxel + (y · R₁ + R₂) / voxel: a loop the compiler
  // vectorises.
  const Eigen::Vector3f across = f_.R.col (0) * f_.inv_voxel, row_dir = (f_.R.col (1) * ray_y + f_.R.col (2)) * f_.inv_voxel;
  for (std::size_t u = 0; u < ray_x_.size (); ++u)
  {
    dirs_x_[u] = row_dir.x () + across.x () * ray_x_[u];
    dirs_y_[u] = row_dir.y () + across.y () * ray_x_[u];
    dirs_z_[u] = row_dir.z () + across.z () * ray_x_[u];
  }
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
  if (vector_hints_)
    castHintedGroups (v, ray_y);
#endif
  for (int u = 0; u < width; ++u)
  {
    const std::size_t tile = static_cast<std::size_t> ((v / RangeTiles::kTile) * tiles.cols + u / RangeTiles::kTile);
    if (!(tiles.zmax[tile] > tiles.zmin[tile]))
      continue;
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
    if (vector_hints_ && hint_z_[static_cast<std::size_t> (u)] > 0.f)
    {
      row_z = hint_z_[static_cast<std::size_t> (u)];  // written by writeSettledRays8
      continue;
    }
#endif
    VoxelHit hit;
    Eigen::Vector3f grad;
    bool skipped = false;
    const float z = castPixel (u, v, tile, row_z, skip_row, skipped, &hit, &grad);
    if (skipped)
    {
      empty_row[u] = 255;  // a skip mask implies a hint, so the output mask exists
      continue;
    }
    if (z <= 0.f)
    {
      if (empty_row != nullptr && !(f_.depth_hint.at<float> (v, u) > 0.f))
        empty_row[u] = 255;
      continue;
    }
    row_z = z;
    const Eigen::Vector3f p = Eigen::Vector3f (ray_x_[static_cast<std::size_t> (u)], ray_y, 1.f) * z;
    vertex_row[u] = cv::Vec3f (p.x (), p.y (), p.z ());
    // Normal from the TSDF gradient at the hit (KinectFusion); differences of
    // neighbouring raycast vertices, one pixel apart, would amplify their sub-millimetre
    // noise into degrees.
    if (grad.squaredNorm () > 0.f)
    {
      Eigen::Vector3f n = (f_.R_cw * grad).normalized ();
      if (n.dot (p) > 0.f)
        n = -n;
      normal_row[u] = cv::Vec3f (n.x (), n.y (), n.z ());
    }
    if (hit.voxel != nullptr)
    {
      __builtin_prefetch (hit.voxel);
      if (f_.values != nullptr)
        if (const std::uint32_t* value = f_.valueOf (hit.number))
          __builtin_prefetch (value);
      hits_[static_cast<std::size_t> (u)] = hit;
    }
  }
  for (int u = 0; u < width; ++u)
  {
    const VoxelHit& hit = hits_[static_cast<std::size_t> (u)];
    color_row[u] = hit.voxel != nullptr ? cv::Vec3b (hit.voxel->b, hit.voxel->g, hit.voxel->r) : cv::Vec3b (0, 0, 0);
    voxel_row[u] = static_cast<std::int32_t> (hit.number);  // kNoVoxel is −1
  }
  if (f_.values != nullptr)
  {
    std::int32_t* value_row = out_.values.ptr<std::int32_t> (v);
    for (int u = 0; u < width; ++u)
    {
      const std::uint32_t* value = f_.valueOf (hits_[static_cast<std::size_t> (u)].number);
      value_row[u] = value != nullptr ? static_cast<std::int32_t> (*value) : 0;
    }
  }
}
}  // namespace

void
TSDFVolume::raycast (const PinholeCamera& camera, const Eigen::Isometry3d& pose, RaycastResult& out, const RaycastOptions& options) const
{
  const cv::Mat& depth_hint = options.depth_hint;
  const RaycastHoleSkip& skip = options.hole_skip;
  const VoxelValueLayer* values = options.values;
  camera.validate ("TSDFVolume::raycast");
  if (!depth_hint.empty () && (depth_hint.type () != CV_32F || depth_hint.cols != camera.width || depth_hint.rows != camera.height))
    throw Error ("TSDFVolume::raycast", "depth hint must be CV_32F of the camera's image size");
  const bool skip_holes = !depth_hint.empty () && !skip.empty_holes.empty ();
  if (skip_holes && (skip.empty_holes.type () != CV_8U || skip.empty_holes.size () != depth_hint.size () ||
                     skip.empty_holes.data == out.empty_holes.data || skip.refresh_period < 1))
    throw Error ("TSDFVolume::raycast", "hole skip mask must be CV_8U of the image size, not the output's own, "
                                        "with a refresh period of at least 1");
  out.camera = camera;
  out.pose = pose;
  const cv::Size size (camera.width, camera.height);
  out.vertices.create (size, CV_32FC3);
  out.normals.create (size, CV_32FC3);
  out.colors.create (size, CV_8UC3);
  out.voxels.create (size, CV_32S);
  if (values != nullptr)
    out.values.create (size, CV_32S);
  else
    out.values.release ();
  if (depth_hint.empty ())
    out.empty_holes.release ();
  else
    out.empty_holes.create (size, CV_8U);

  const float voxel_size = static_cast<float> (config_.voxel_size);
  const Eigen::Isometry3f world_to_camera = pose.inverse ().cast<float> ();
  const float near = static_cast<float> (std::max (config_.min_depth, 0.01));
  const RangeTiles tiles = blockRanges (store_.blockIndices (), camera, world_to_camera, static_cast<float> (config_.blockSize ()), near);
  const Eigen::Matrix3f R = pose.linear ().cast<float> ();
  const float inv_voxel = 1.f / voxel_size;
  const RayFrame frame{camera,
                       depth_hint,
                       skip,
                       skip_holes,
                       tiles,
                       R,
                       R.transpose (),
                       pose.translation ().cast<float> () * inv_voxel,
                       inv_voxel,
                       static_cast<float> (config_.truncation_voxels),
                       static_cast<float> (2.0 * config_.voxel_size),
                       static_cast<float> (config_.truncation ()),
                       static_cast<float> (1.0 / camera.fx),
                       static_cast<float> (1.0 / camera.fy),
                       static_cast<float> (camera.cx),
                       static_cast<float> (camera.cy),
                       vectorKernelsEnabled (),
                       values};
  parallelForChunks (camera.height, 4, [&] (int, int begin, int end) {
    RowCaster rows (*this, frame, out);
    for (int v = begin; v < end; ++v)
      rows.castRow (v);
  });
}
}  // namespace reconstruction
}  // namespace cuefusion
