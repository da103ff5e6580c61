// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/segment_propagation.h>

#include "overlap_table.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>


namespace cuefusion
{
namespace segmentation
{
namespace
{
/** \brief §4.2.2.3's distance test at one pixel whose normals already agree: the frame's
  * and the model's vertex lie within k·σ_d(u) of each other along the viewing ray (σ_d
  * at θ = 0 first, a lower bound; the angle's exact σ_d only where that fails, or at
  * once with \a exact_only). False where a vertex is not finite.
  */
inline bool
agreesOnSurface (const cv::Vec3f& v, const cv::Vec3f& n, const cv::Vec3f& vm, float noise_factor, bool exact_only)
{
  const Eigen::Vector3f V (v[0], v[1], v[2]), N (n[0], n[1], n[2]), Vm (vm[0], vm[1], vm[2]);
  if (!isFiniteVector (V) || !isFiniteVector (Vm))
    return false;
  const float along_ray = std::abs ((V - Vm).dot (V)) / V.norm ();
  return (!exact_only && along_ray < noise_factor * axialNoiseLowerBound (V.z ())) ||
         along_ray < noise_factor * axialNoiseAt (V, N);
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
/** \brief kinectAxialNoise's angular term, scale · θ²/(π/2 − θ)², in eight lanes. */
CUEFUSION_AVX2 inline __m256
angularNoise8 (__m256 scale, __m256 theta)
{
  const __m256 rest = _mm256_sub_ps (_mm256_set1_ps (1.57079632679489661923f), theta);
  return _mm256_div_ps (_mm256_mul_ps (scale, _mm256_mul_ps (theta, theta)), _mm256_mul_ps (rest, rest));
}

/** \brief The per-pixel tests of §4.2.2.3 for eight pixels (CV_32FC3 rows at the
  * pointers, labels L_t \a lj and L^m \a li): returns the lanes with a frame label;
  * \a accepted gets the lanes that pass everything, \a exact those too close to σ_d to
  * decide without its acos (the caller runs the exact test there), \a without_normal those
  * without a frame normal whose distance alone passes at normal incidence's σ_d (the
  * caller counts them for segments mostly without normals).
  */
CUEFUSION_AVX2 int
agreeingPixels8 (const float* v, const float* n, const float* vm, const float* nm, const std::int32_t* lj,
                 const std::int32_t* li, float normal_agreement, float noise_factor, int& accepted, int& exact,
                 int& without_normal)
{
  const __m256i zero_i = _mm256_setzero_si256 ();
  const __m256i frame_label = _mm256_cmpgt_epi32 (_mm256_loadu_si256 (reinterpret_cast<const __m256i*> (lj)), zero_i);
  const int labelled = _mm256_movemask_ps (_mm256_castsi256_ps (frame_label));
  accepted = exact = without_normal = 0;
  const __m256i both = _mm256_and_si256 (frame_label, _mm256_cmpgt_epi32 (_mm256_loadu_si256 (reinterpret_cast<const __m256i*> (li)), zero_i));
  if (_mm256_movemask_ps (_mm256_castsi256_ps (both)) == 0)
    return labelled;
  __m256 vx, vy, vz, nx, ny, nz, mx, my, mz, qx, qy, qz;
  avx2::loadXyz8 (v, vx, vy, vz);
  avx2::loadXyz8 (n, nx, ny, nz);
  avx2::loadXyz8 (vm, mx, my, mz);
  avx2::loadXyz8 (nm, qx, qy, qz);
  const __m256 frame_normal = avx2::finite (nx, ny, nz);
  const __m256 points = _mm256_and_ps (_mm256_castsi256_ps (both), _mm256_and_ps (avx2::finite (vx, vy, vz), avx2::finite (mx, my, mz)));
  const __m256 no_normal = _mm256_andnot_ps (frame_normal, points);
  __m256 ok = _mm256_and_ps (points, _mm256_and_ps (frame_normal, avx2::finite (qx, qy, qz)));
  const __m256 agreement = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (nx, qx), _mm256_mul_ps (ny, qy)), _mm256_mul_ps (nz, qz));
  ok = _mm256_and_ps (ok, _mm256_cmp_ps (agreement, _mm256_set1_ps (normal_agreement), _CMP_GT_OQ));
  const __m256 dot = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (_mm256_sub_ps (vx, mx), vx), _mm256_mul_ps (_mm256_sub_ps (vy, my), vy)),
                                    _mm256_mul_ps (_mm256_sub_ps (vz, mz), vz));
  const __m256 length = _mm256_sqrt_ps (_mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (vx, vx), _mm256_mul_ps (vy, vy)), _mm256_mul_ps (vz, vz)));
  const __m256 along_ray = _mm256_div_ps (avx2::abs (dot), length);
  const __m256 bound = avx2::kinectNoiseAtNormalIncidence (vz);  // axialNoiseLowerBound
  const __m256 k = _mm256_set1_ps (noise_factor);
  const __m256 near = _mm256_cmp_ps (along_ray, _mm256_mul_ps (k, bound), _CMP_LT_OQ);
  accepted = _mm256_movemask_ps (_mm256_and_ps (ok, near));
  without_normal = _mm256_movemask_ps (_mm256_and_ps (no_normal, near));
  const __m256 beyond_bound = _mm256_andnot_ps (near, ok);
  if (_mm256_movemask_ps (beyond_bound) == 0)
    return labelled;
  // Past the bound at θ = 0, σ_d(θ) decides; it grows with θ, and with c = cos θ,
  // √(2(1 − c)) ≤ θ ≤ (π/2)√(1 − c) on [0, π/2]. σ_d at both ends brackets the exact one
  // (kinectAxialNoise: bound + 0.0001/√z · θ²/(π/2 − θ)², θ ≤ π/2 − 10⁻³): below the lower
  // end a pixel agrees, above the upper end it does not, and only the few in between go
  // to agreesOnSurface's acos. A 10⁻³ relative margin on both sides keeps float rounding
  // from deciding differently from that exact test. (The exact test per lane was most of
  // the propagation's time on Kinect data, where many pixels fail the θ = 0 bound.)
  const __m256 normal_dot = _mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (vx, nx), _mm256_mul_ps (vy, ny)), _mm256_mul_ps (vz, nz));
  const __m256 one = _mm256_set1_ps (1.f);
  const __m256 c = _mm256_min_ps (one, _mm256_div_ps (avx2::abs (normal_dot), length));
  const __m256 root = _mm256_sqrt_ps (_mm256_max_ps (_mm256_sub_ps (one, c), _mm256_setzero_ps ()));
  const __m256 half_pi = _mm256_set1_ps (1.57079632679489661923f), theta_max = _mm256_set1_ps (1.57079632679489661923f - 1e-3f);
  const __m256 theta_lo = _mm256_min_ps (_mm256_mul_ps (_mm256_set1_ps (1.41421356237309504880f), root), theta_max);
  const __m256 theta_hi = _mm256_min_ps (_mm256_mul_ps (half_pi, root), theta_max);
  const __m256 scale = _mm256_div_ps (_mm256_set1_ps (0.0001f), _mm256_sqrt_ps (_mm256_max_ps (vz, _mm256_set1_ps (1e-6f))));
  const __m256 sigma_lo = _mm256_add_ps (bound, angularNoise8 (scale, theta_lo));
  const __m256 sigma_hi = _mm256_add_ps (bound, angularNoise8 (scale, theta_hi));
  const __m256 surely = _mm256_cmp_ps (along_ray, _mm256_mul_ps (_mm256_mul_ps (k, sigma_lo), _mm256_set1_ps (1.f - 1e-3f)), _CMP_LT_OQ);
  const __m256 maybe = _mm256_cmp_ps (along_ray, _mm256_mul_ps (_mm256_mul_ps (k, sigma_hi), _mm256_set1_ps (1.f + 1e-3f)), _CMP_LT_OQ);
  accepted |= _mm256_movemask_ps (_mm256_and_ps (beyond_bound, surely));
  exact = _mm256_movemask_ps (_mm256_andnot_ps (surely, _mm256_and_ps (beyond_bound, maybe)));
  return labelled;
}
#endif

/** \brief L^p: every pixel of frame segment j gets the label given to j. */
void
finishLabels (const cv::Mat& frame_labels, const std::vector<std::uint32_t>& given, PropagationResult& result)
{
  result.labels.create (frame_labels.size (), CV_32S);
  parallelFor (frame_labels.rows, [&] (int y) {
    const std::int32_t* lj = frame_labels.ptr<std::int32_t> (y);
    std::int32_t* out = result.labels.ptr<std::int32_t> (y);
    for (int x = 0; x < frame_labels.cols; ++x)
      out[x] = lj[x] > 0 ? static_cast<std::int32_t> (given[static_cast<std::size_t> (lj[x])]) : 0;
  });
}

/** Per frame label l_j: #l_j (its pixels) and Π(l_i, l_j) for each model label l_i it
  * meets, over the pixels where both maps agree (§4.2.2.3). */
using FrameOverlaps = OverlapTable<std::uint32_t>;

constexpr int kRowsPerChunk = 16;  ///< rows per work item of the row loops below

/** Per frame label, its pixels without a frame normal (size) and where the distance
  * alone agrees with a model label there (overlap). */
using WithoutNormals = OverlapTable<std::uint32_t>;

/** Counts FrameOverlaps over the images (\a labels = largest frame label + 1). */
FrameOverlaps
countOverlaps (const SegmentPropagationConfig& config, const cv::Mat& vertices, const cv::Mat& normals, const cv::Mat& frame_labels,
               const cv::Mat& model_vertices, const cv::Mat& model_normals, const cv::Mat& model_labels, std::size_t labels)
{
  const cv::Size size = frame_labels.size ();
  // Rows in fixed chunks on the pool, each with its own counts, added up in chunk order
  // (the lists keep first-seen order, so the result does not depend on the thread count).
  // Pixels without a frame normal are counted apart (their share, and where the distance
  // alone agrees), since whether a segment is edge-bound is known only at the end.
  const int chunks = chunkCount (size.height, kRowsPerChunk);
  [[maybe_unused]] const bool use_avx2 = vectorKernelsEnabled ();
  std::vector<FrameOverlaps> chunk_overlaps (static_cast<std::size_t> (chunks));
  std::vector<WithoutNormals> chunk_without (static_cast<std::size_t> (chunks));
  parallelForChunks (size.height, kRowsPerChunk, [&] (int k, int begin, int end) {
    FrameOverlaps& overlaps = chunk_overlaps[static_cast<std::size_t> (k)];
    WithoutNormals& without = chunk_without[static_cast<std::size_t> (k)];
    overlaps = FrameOverlaps (labels);
    without = WithoutNormals (labels);
    std::vector<int>& counts = overlaps.size;
    for (int y = begin; y < end; ++y)
    {
      const std::int32_t* lj = frame_labels.ptr<std::int32_t> (y);
      const std::int32_t* li = model_labels.ptr<std::int32_t> (y);
      const cv::Vec3f* v_row = vertices.ptr<cv::Vec3f> (y);
      const cv::Vec3f* n_row = normals.ptr<cv::Vec3f> (y);
      const cv::Vec3f* vm_row = model_vertices.ptr<cv::Vec3f> (y);
      const cv::Vec3f* nm_row = model_normals.ptr<cv::Vec3f> (y);
      // Model labels as allocated, not resolved: objects are groups of them.
      const auto overlap = [&] (int x) {
        overlaps.add (static_cast<std::size_t> (lj[x]), static_cast<std::uint32_t> (li[x]), 1);
      };
      int x = 0;
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
      if (use_avx2)
        for (; x + 8 <= size.width; x += 8)
        {
          int accepted = 0, exact = 0, without_normal = 0;
          const int labelled = agreeingPixels8 (&v_row[x][0], &n_row[x][0], &vm_row[x][0], &nm_row[x][0], lj + x, li + x,
                                                config.normal_agreement, config.noise_factor, accepted, exact, without_normal);
          for (int m = without_normal; m != 0; m &= m - 1)
          {
            const int i = x + __builtin_ctz (static_cast<unsigned> (m));
            without.add (static_cast<std::size_t> (lj[i]), static_cast<std::uint32_t> (li[i]), 1);
          }
          for (int m = labelled; m != 0; m &= m - 1)
          {
            const int i = x + __builtin_ctz (static_cast<unsigned> (m));
            ++counts[static_cast<std::size_t> (lj[i])];
            without.size[static_cast<std::size_t> (lj[i])] += std::isfinite (n_row[i][2]) ? 0 : 1;
          }
          for (int m = exact; m != 0; m &= m - 1)
          {
            // Failed the bound at θ = 0: the exact σ_d(u) of the viewing angle decides.
            const int i = x + __builtin_ctz (static_cast<unsigned> (m));
            if (agreesOnSurface (v_row[i], n_row[i], vm_row[i], config.noise_factor, true))
              accepted |= 1 << (i - x);
          }
          for (int m = accepted; m != 0; m &= m - 1)
            overlap (x + __builtin_ctz (static_cast<unsigned> (m)));
        }
#endif
      for (; x < size.width; ++x)
      {
        if (lj[x] <= 0)
          continue;
        ++counts[static_cast<std::size_t> (lj[x])];
        without.size[static_cast<std::size_t> (lj[x])] += std::isfinite (n_row[x][2]) ? 0 : 1;
        if (li[x] <= 0)
          continue;
        const Eigen::Vector3f N (n_row[x][0], n_row[x][1], n_row[x][2]), Nm (nm_row[x][0], nm_row[x][1], nm_row[x][2]);
        if (!isFiniteVector (N))
        {
          // No frame normal: the distance alone, at normal incidence's σ_d.
          if (agreesOnSurface (v_row[x], n_row[x], vm_row[x], config.noise_factor, false))
            without.add (static_cast<std::size_t> (lj[x]), static_cast<std::uint32_t> (li[x]), 1);
          continue;
        }
        if (!isFiniteVector (Nm) || !(N.dot (Nm) > config.normal_agreement))
          continue;
        if (agreesOnSurface (v_row[x], n_row[x], vm_row[x], config.noise_factor, false))
          overlap (x);
      }
    }
  });
  FrameOverlaps out (labels);
  WithoutNormals without (labels);
  for (std::size_t k = 0; k < chunk_overlaps.size (); ++k)
  {
    out.add (chunk_overlaps[k]);
    without.add (chunk_without[k]);
  }
  // Edge-bound segments (more than half of their pixels without a frame normal): a far,
  // thin object (a cup 13 px wide between two boxes at 3 m) lies within the normals' span
  // of depth edges nearly everywhere and would meet no model label under §4.2.2.3's normal
  // test, taking a fresh label every frame; there the distance alone decides. Larger
  // segments keep the reference's test everywhere (with it for all pixels, a room's floor
  // took the wall's label along their crease).
  for (std::size_t l = 1; l < labels; ++l)
    if (2 * without.size[l] > out.size[l])
      for (const auto& [model_label, count] : without.overlap[l])
        out.add (l, model_label, count);
  return out;
}

/** What the masks say of each frame segment: claimed by instance k (k ≥ 0), left out
  * (kLeftOut), or nothing (kUnsure: unsure, or no masks at all). */
constexpr int kUnsure = -1, kLeftOut = -2;

std::vector<int>
maskIdentities (const SegmentPropagationConfig& config, const std::vector<SegmentInstance>* segments, std::size_t labels)
{
  std::vector<int> identity (labels, kUnsure);
  if (segments)
    for (std::size_t j = 1; j < labels && j < segments->size (); ++j)
    {
      const SegmentInstance& info = (*segments)[j];
      identity[j] = info.instance >= 0 ? info.instance : (info.coverage < config.uncovered_overlap ? kLeftOut : kUnsure);
    }
  return identity;
}

/** §4.2.2.4: each segment's best model label (inherit) or 0 (fresh); segments below the
  * minimum size are counted as dropped. Sorts each segment's overlap list. */
std::vector<std::uint32_t>
wantedLabels (const SegmentPropagationConfig& config, FrameOverlaps& overlaps, PropagationResult& result)
{
  const std::size_t labels = overlaps.labels ();
  std::vector<std::uint32_t> wanted (labels, 0);
  for (std::size_t j = 1; j < labels; ++j)
  {
    const int count = overlaps.size[j];
    if (count == 0)
      continue;
    if (count < config.min_segment_size)
    {
      ++result.dropped;
      continue;
    }
    auto& list = overlaps.overlap[j];
    std::sort (list.begin (), list.end ());
    int best_count = 0;
    for (const auto& [li, c] : list)
      if (c > best_count)
      {
        wanted[j] = li;
        best_count = c;
      }
    if (!(static_cast<float> (best_count) > config.inherit_overlap * static_cast<float> (count)))
      wanted[j] = 0;
  }
  return wanted;
}

/** Label claims of the segments the masks set apart: label → identity → Π. */
using Claims = std::map<std::uint32_t, std::map<int, int>>;

/** The label that identity \a identity gets when it lost \a label to another identity:
  * the label's successors in the order they were made (the same objects keep the same
  * labels while the voxels still carry the old one), a fresh successor when they run out;
  * one per (lost label, identity), remembered in \a fresh_for. */
std::uint32_t
successorFor (std::uint32_t label, int identity, std::map<std::pair<std::uint32_t, int>, std::uint32_t>& fresh_for, GlobalSegmentMap& map,
              std::size_t frame, PropagationResult& result)
{
  auto it = fresh_for.find ({label, identity});
  if (it == fresh_for.end ())
  {
    std::uint32_t unused = 0;
    for (const std::uint32_t s : map.successors (label))
    {
      bool taken = false;
      for (const auto& [key, given_label] : fresh_for)
        taken = taken || (key.first == label && given_label == s);
      if (!taken)
      {
        unused = s;
        break;
      }
    }
    if (!unused)
    {
      unused = map.newSuccessor (label, frame);
      ++result.fresh;
    }
    it = fresh_for.emplace (std::make_pair (label, identity), unused).first;
  }
  return it->second;
}

/** The global label of each frame segment (0: dropped): its wanted label unless the masks
  * set it apart from the segments holding that label more (then the next label above τ_l
  * no other identity claims, else a successor of the lost label), else a fresh one. */
std::vector<std::uint32_t>
giveLabels (const SegmentPropagationConfig& config, const FrameOverlaps& overlaps, const std::vector<std::uint32_t>& wanted,
            const std::vector<int>& identity, const std::vector<SegmentInstance>* segments, GlobalSegmentMap& map, std::size_t frame,
            PropagationResult& result)
{
  const std::size_t labels = wanted.size ();
  // Segments the masks set apart do not share a label: per wanted label, the identity
  // with the largest Π keeps it (unsure segments side with anyone).
  Claims claims;
  for (std::size_t j = 1; j < labels; ++j)
    if (wanted[j] && identity[j] != kUnsure)
      for (const auto& [li, c] : overlaps.overlap[j])
        if (li == wanted[j])
          claims[wanted[j]][identity[j]] += c;
  std::map<std::pair<std::uint32_t, int>, std::uint32_t> fresh_for;  // (lost label, identity) → its fresh label
  std::vector<std::uint32_t> given (labels, 0);
  for (std::size_t j = 1; j < labels; ++j)
  {
    if (overlaps.size[j] < config.min_segment_size)
      continue;
    std::uint32_t label = wanted[j];
    bool successor = false;  // a successor of a lost label: neither inherited nor (unless new) fresh
    if (label && identity[j] != kUnsure)
    {
      int winner = kUnsure, winner_pi = -1;
      for (const auto& [id, pi] : claims[label])
        if (pi > winner_pi)
        {
          winner = id;
          winner_pi = pi;
        }
      if (winner != identity[j])
      {
        std::uint32_t next = 0;
        int next_count = 0;
        for (const auto& [li, c] : overlaps.overlap[j])
          if (li != label && c > next_count &&
              static_cast<float> (c) > config.inherit_overlap * static_cast<float> (overlaps.size[j]))
          {
            const auto other = claims.find (li);
            if (other == claims.end () || other->second.empty () || other->second.count (identity[j]))
            {
              next = li;
              next_count = c;
            }
          }
        successor = next == 0;
        label = next ? next : successorFor (label, identity[j], fresh_for, map, frame, result);
      }
    }
    if (!label)
    {
      label = map.newSegment (frame);
      ++result.fresh;
    }
    else if (!successor)
      ++result.inherited;
    given[j] = label;
    map.observe (label, frame, segments && j < segments->size () ? &(*segments)[j] : nullptr);
  }
  return given;
}

/** §4.2.3 as evidence: each map segment seen well enough, with the frame segment holding
  * most of its agreeing pixels, by label. */
std::vector<std::pair<std::uint32_t, std::size_t>>
placeMapSegments (const SegmentPropagationConfig& config, const FrameOverlaps& overlaps)
{
  struct Sighting
  {
    int visible = 0, best = 0;  ///< agreeing pixels in all, and in the frame segment holding most
    std::size_t segment = 0;
  };
  std::map<std::uint32_t, Sighting> seen;  // by model label
  for (std::size_t j = 1; j < overlaps.labels (); ++j)
    for (const auto& [li, c] : overlaps.overlap[j])
    {
      Sighting& s = seen[li];
      s.visible += c;
      if (c > s.best)
      {
        s.best = c;
        s.segment = j;
      }
    }
  std::vector<std::pair<std::uint32_t, std::size_t>> placed;  // (model label, frame segment), by label
  for (const auto& [li, s] : seen)
    if (li != 0 && s.visible >= config.min_segment_size &&
        static_cast<float> (s.best) > config.placement_share * static_cast<float> (s.visible))
      placed.emplace_back (li, s.segment);
  return placed;
}

/** How two frame segments that touch are parted: boundary samples where the frame shows a
  * geometric edge and the model (V^m, N^m) is there on both sides, and those of them where
  * the model shows the edge too. */
struct Boundary
{
  int judged = 0, edges = 0;
};
using TouchingSegments = std::map<std::pair<std::size_t, std::size_t>, Boundary>;

/** \brief Whether a surface (vertex and normal maps, CV_32FC3) shows an edge between pixels
  * \a p and \a q: a depth jump of more than k·σ_d off either tangent plane (Γ, the
  * depth-edge test) or a concave crease (Φ below the thesis's threshold, symmetric
  * convexity test). -1 where it has no surface at one of them.
  */
inline int
edgeBetween (const cv::Vec3f* vm, const cv::Vec3f* nm, std::size_t p, std::size_t q, float noise_factor)
{
  const Eigen::Vector3f vp (vm[p][0], vm[p][1], vm[p][2]), vq (vm[q][0], vm[q][1], vm[q][2]);
  const Eigen::Vector3f np (nm[p][0], nm[p][1], nm[p][2]), nq (nm[q][0], nm[q][1], nm[q][2]);
  if (!isFiniteVector (vp) || !isFiniteVector (vq) || !isFiniteVector (np) || !isFiniteVector (nq))
    return -1;
  static const float crease = ConcavityEdgeEstimationConfig ().threshold;
  const bool jump = isDepthDiscontinuity (discontinuityTerm (vp, np, vq), noise_factor, vp, np) ||
                    isDepthDiscontinuity (discontinuityTerm (vq, nq, vp), noise_factor, vq, nq);
  return jump || concavityTermSymmetric (vp, np, vq, nq) < crease ? 1 : 0;
}

/** Frame segments that touch (within 2 pixels along a row or a column: an edge, or a
  * mask's cut, lies between them), by (smaller, larger) pair, with what the model shows
  * across the samples of their boundary where the frame shows an edge. Gathered per row
  * chunk, then summed. */
TouchingSegments
touchingSegments (const cv::Mat& frame_labels, const cv::Mat& vertices, const cv::Mat& normals, const cv::Mat& model_vertices,
                  const cv::Mat& model_normals, float noise_factor)
{
  const cv::Size size = frame_labels.size ();
  const auto* v = vertices.ptr<cv::Vec3f> ();
  const auto* n = normals.ptr<cv::Vec3f> ();
  const auto* vm = model_vertices.ptr<cv::Vec3f> ();
  const auto* nm = model_normals.ptr<cv::Vec3f> ();
  std::vector<TouchingSegments> chunk_touching (static_cast<std::size_t> (chunkCount (size.height, kRowsPerChunk)));
  parallelForChunks (size.height, kRowsPerChunk, [&] (int k, int begin, int end) {
    TouchingSegments& found = chunk_touching[static_cast<std::size_t> (k)];
    // Boundary samples come in runs of one pair: the last pair's entry saves a map lookup
    // per sample (std::map's nodes stay where they are as others are added).
    std::pair<std::size_t, std::size_t> last_pair{0, 0};
    Boundary* last = nullptr;
    for (int y = begin; y < end; ++y)
    {
      const std::int32_t* row = frame_labels.ptr<std::int32_t> (y);
      const std::int32_t* below[2] = {y + 1 < size.height ? frame_labels.ptr<std::int32_t> (y + 1) : nullptr,
                                      y + 2 < size.height ? frame_labels.ptr<std::int32_t> (y + 2) : nullptr};
      for (int x = 0; x < size.width; ++x)
      {
        const std::int32_t a = row[x];
        if (a <= 0)
          continue;
        const std::int32_t others[4] = {x + 1 < size.width ? row[x + 1] : 0, x + 2 < size.width ? row[x + 2] : 0,
                                        below[0] ? below[0][x] : 0, below[1] ? below[1][x] : 0};
        const std::size_t here = static_cast<std::size_t> (y) * size.width + x;
        const std::size_t there[4] = {here + 1, here + 2, here + size.width, here + 2 * static_cast<std::size_t> (size.width)};
        for (int o = 0; o < 4; ++o)
        {
          const std::int32_t b = others[o];
          if (b <= 0 || b == a)
            continue;
          const std::pair<std::size_t, std::size_t> pair{static_cast<std::size_t> (std::min (a, b)), static_cast<std::size_t> (std::max (a, b))};
          if (!last || pair != last_pair)
          {
            last = &found[pair];
            last_pair = pair;
          }
          Boundary& boundary = *last;
          // Only where the frame's own surface parts them: a cut along a mask or a colour
          // boundary is no geometric edge for the model to confirm or deny.
          if (edgeBetween (v, n, here, there[o], noise_factor) != 1)
            continue;
          const int edge = edgeBetween (vm, nm, here, there[o], noise_factor);
          if (edge >= 0)
          {
            ++boundary.judged;
            boundary.edges += edge;
          }
        }
      }
    }
  });
  TouchingSegments touching;
  for (const TouchingSegments& found : chunk_touching)
    for (const auto& [pair, boundary] : found)
    {
      Boundary& sum = touching[pair];
      sum.judged += boundary.judged;
      sum.edges += boundary.edges;
    }
  return touching;
}

/** The votes on each pair of placed map segments: together when one frame segment or one
  * instance holds both, apart when the masks set them apart (adjacent, or already a tracked
  * pair). Where no mask speaks for either and they touch, the fused surface decides
  * (SegmentPropagationConfig::model_edge_share): apart where it shows an edge along enough
  * of their boundary (or cannot be judged), together where the frame's edge was noise it
  * has averaged away. */
void
voteOnPairs (const SegmentPropagationConfig& config, const std::vector<std::pair<std::uint32_t, std::size_t>>& placed,
             const TouchingSegments& touching, const std::vector<int>& identity, const GlobalSegmentMap& map,
             PropagationResult& result)
{
  // Fewer judged samples than this (a corner, a boundary the model has not seen) leave the
  // frame's edge to speak: two pixels' worth of boundary along 10 rows or columns.
  constexpr int kMinJudged = 20;
  for (std::size_t p = 0; p < placed.size (); ++p)
    for (std::size_t q = p + 1; q < placed.size (); ++q)
    {
      const auto [a, ja] = placed[p];
      const auto [b, jb] = placed[q];
      if (ja == jb)
      {
        result.votes.emplace_back (a, b, PairVote::Together);
        continue;
      }
      const int ia = identity[ja], ib = identity[jb];
      const auto boundary = touching.find (std::make_pair (std::min (ja, jb), std::max (ja, jb)));
      const bool adjacent = boundary != touching.end ();
      if (ia >= 0 && ia == ib)
        result.votes.emplace_back (a, b, PairVote::Together);
      else if ((ia >= 0 && ib >= 0) || (ia >= 0 && ib == kLeftOut) || (ia == kLeftOut && ib >= 0))
      {
        if (adjacent || map.evidence ().tracked (a, b))
          result.votes.emplace_back (a, b, PairVote::Apart);
      }
      else if (adjacent && ia < 0 && ib < 0)
      {
        const Boundary& seen = boundary->second;  // judged: where the frame shows an edge
        const bool smooth = seen.judged >= kMinJudged && seen.edges < config.model_edge_share * seen.judged;
        result.votes.emplace_back (a, b, smooth ? PairVote::Together : PairVote::Apart);
      }
    }
}
}  // namespace


void
SegmentPropagationConfig::validate () const
{
  if (!(normal_agreement >= -1.f && normal_agreement <= 1.f))
    throw ParameterError ("SegmentPropagationConfig::normal_agreement", "must lie in [-1, 1]");
  if (!(inherit_overlap >= 0.f && inherit_overlap < 1.f))
    throw ParameterError ("SegmentPropagationConfig::inherit_overlap", "must lie in [0, 1)");
  if (!(placement_share >= 0.5f && placement_share < 1.f))
    throw ParameterError ("SegmentPropagationConfig::placement_share", "must lie in [0.5, 1)");
  if (!(uncovered_overlap >= 0.f && uncovered_overlap < 1.f))
    throw ParameterError ("SegmentPropagationConfig::uncovered_overlap", "must lie in [0, 1)");
  if (!(noise_factor > 0.f && std::isfinite (noise_factor)))
    throw ParameterError ("SegmentPropagationConfig::noise_factor", "must be positive");
  if (min_segment_size < 1)
    throw ParameterError ("SegmentPropagationConfig::min_segment_size", "must be at least 1 pixel");
  if (!(model_edge_share >= 0.f && model_edge_share <= 1.f))
    throw ParameterError ("SegmentPropagationConfig::model_edge_share", "must lie in [0, 1]");
}

SegmentPropagation::SegmentPropagation (const SegmentPropagationConfig& config) : config_ (config) { config_.validate (); }

void
SegmentPropagation::propagate (const cv::Mat& vertices, const cv::Mat& normals, const cv::Mat& frame_labels,
                               const cv::Mat& model_vertices, const cv::Mat& model_normals, const cv::Mat& model_labels,
                               GlobalSegmentMap& map, std::size_t frame, PropagationResult& result,
                               const std::vector<SegmentInstance>* segments) const
{
  const cv::Size size = frame_labels.size ();
  for (const cv::Mat* m : {&vertices, &normals, &model_vertices, &model_normals})
    if (m->type () != CV_32FC3 || m->size () != size)
      throw Error ("SegmentPropagation", "vertex and normal maps must be CV_32FC3 of L_t's size");
  if (frame_labels.type () != CV_32S || model_labels.type () != CV_32S || model_labels.size () != size)
    throw Error ("SegmentPropagation", "label maps must be CV_32S of one size");

  // Frame labels are small (1..N), so per-label vectors; each holds the few (l_i, Π) it meets.
  double max_frame_label = 0.0;
  cv::minMaxLoc (frame_labels, nullptr, &max_frame_label);
  const std::size_t labels = static_cast<std::size_t> (std::max (0.0, max_frame_label)) + 1;
  FrameOverlaps overlaps =
    countOverlaps (config_, vertices, normals, frame_labels, model_vertices, model_normals, model_labels, labels);
  const std::vector<int> identity = maskIdentities (config_, segments, labels);
  result = PropagationResult ();
  const std::vector<std::uint32_t> wanted = wantedLabels (config_, overlaps, result);
  const std::vector<std::uint32_t> given = giveLabels (config_, overlaps, wanted, identity, segments, map, frame, result);
  const std::vector<std::pair<std::uint32_t, std::size_t>> placed = placeMapSegments (config_, overlaps);
  if (placed.size () >= 2)
    voteOnPairs (config_, placed,
                 touchingSegments (frame_labels, vertices, normals, model_vertices, model_normals, config_.noise_factor),
                 identity, map, result);
  finishLabels (frame_labels, given, result);
}


}  // namespace segmentation
}  // namespace cuefusion
