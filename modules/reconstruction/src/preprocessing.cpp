// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <vector>


namespace cuefusion
{
namespace reconstruction
{
namespace
{
const float kNaN = std::numeric_limits<float>::quiet_NaN ();

/** \brief Which of a 2×2 block's samples to average: valid and near the nearest one. */
inline int
blockSelection (const float z[4], float max_jump)
{
  float nearest = std::numeric_limits<float>::infinity ();
  for (int i = 0; i < 4; ++i)
    if (z[i] > 0.f && z[i] < nearest)
      nearest = z[i];
  int mask = 0;
  if (std::isinf (nearest))
    return mask;
  for (int i = 0; i < 4; ++i)
    if (z[i] > 0.f && z[i] - nearest <= max_jump * nearest)
      mask |= 1 << i;
  return mask;
}
}  // namespace

void
computeVertexMap (const cv::Mat& depth, const PinholeCamera& camera, cv::Mat& vertices)
{
  vertices.create (depth.size (), CV_32FC3);
  // PinholeCamera::backProject's factors per column and row, computed once: the same
  // floats without its two double divisions per pixel.
  std::vector<float> column_factor (static_cast<std::size_t> (depth.cols));
  for (int u = 0; u < depth.cols; ++u)
    column_factor[static_cast<std::size_t> (u)] = static_cast<float> ((static_cast<float> (u) - camera.cx) / camera.fx);
  parallelForChunks (depth.rows, 8, [&] (int, int begin, int end) {
    for (int v = begin; v < end; ++v)
    {
      const float* d = depth.ptr<float> (v);
      float* out = vertices.ptr<float> (v);
      const float row_factor = static_cast<float> ((static_cast<float> (v) - camera.cy) / camera.fy);
      for (int u = 0; u < depth.cols; ++u)
      {
        const bool valid = d[u] > 0.f && std::isfinite (d[u]);
        out[3 * u] = valid ? column_factor[static_cast<std::size_t> (u)] * d[u] : kNaN;
        out[3 * u + 1] = valid ? row_factor * d[u] : kNaN;
        out[3 * u + 2] = valid ? d[u] : kNaN;
      }
    }
  });
}

void
downsampleDepth (const cv::Mat& depth, cv::Mat& half, float max_jump)
{
  half.create (depth.rows / 2, depth.cols / 2, CV_32F);
  parallelForChunks (half.rows, 8, [&] (int, int begin, int end) {
    for (int y = begin; y < end; ++y)
    {
      const float* r0 = depth.ptr<float> (2 * y);
      const float* r1 = depth.ptr<float> (2 * y + 1);
      float* out = half.ptr<float> (y);
      for (int x = 0; x < half.cols; ++x)
      {
        const float z[4] = {r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]};
        const int mask = blockSelection (z, max_jump);
        float sum = 0.f;
        int count = 0;
        for (int i = 0; i < 4; ++i)
          if (mask & (1 << i))
          {
            sum += z[i];
            ++count;
          }
        out[x] = count ? sum / static_cast<float> (count) : 0.f;
      }
    }
  });
}

namespace
{
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
/** \brief Even and odd pixels of sixteen consecutive ones (lanes of \a a, then \b). */
CUEFUSION_AVX2 inline void
splitEvenOdd (__m256 a, __m256 b, __m256& even, __m256& odd)
{
  // Per 128-bit half the shuffle takes a0 a2 b0 b2 | a4 a6 b4 b6; the permute sorts them.
  even = _mm256_castpd_ps (_mm256_permute4x64_pd (_mm256_castps_pd (_mm256_shuffle_ps (a, b, _MM_SHUFFLE (2, 0, 2, 0))),
                                                  _MM_SHUFFLE (3, 1, 2, 0)));
  odd = _mm256_castpd_ps (_mm256_permute4x64_pd (_mm256_castps_pd (_mm256_shuffle_ps (a, b, _MM_SHUFFLE (3, 1, 3, 1))),
                                                 _MM_SHUFFLE (3, 1, 2, 0)));
}

/** \brief The 2×2 blocks under eight output pixels of a 3-float map, from its rows \a top
  * and \a bottom: c[i] is corner i (as in the scalar loop: top left, top right, bottom
  * left, bottom right) as x, y, z vectors.
  */
CUEFUSION_AVX2 inline void
loadBlockCorners8 (const float* top, const float* bottom, __m256 (&c)[4][3])
{
  const float* rows[2] = {top, bottom};
  for (int r = 0; r < 2; ++r)
  {
    __m256 a[3], b[3];
    avx2::loadXyz8 (rows[r], a[0], a[1], a[2]);
    avx2::loadXyz8 (rows[r] + 24, b[0], b[1], b[2]);
    for (int k = 0; k < 3; ++k)
      splitEvenOdd (a[k], b[k], c[2 * r][k], c[2 * r + 1][k]);
  }
}

/** \brief downsampleVertexNormalMaps for eight output pixels from input column 2·x0 on:
  * the scalar loop's selection, sums (in the same order) and divisions, lane by lane —
  * without FMA contraction (the scalar code has none), so results agree to the bit.
  */
CUEFUSION_AVX2 __attribute__ ((optimize ("fp-contract=off"))) void
downsampleVertexNormal8 (const float* v_top, const float* v_bottom, const float* n_top, const float* n_bottom,
                         float max_jump, float* v_out, float* n_out)
{
  __m256 v[4][3], n[4][3];
  loadBlockCorners8 (v_top, v_bottom, v);
  loadBlockCorners8 (n_top, n_bottom, n);
  const __m256 zero = _mm256_setzero_ps (), inf = _mm256_set1_ps (std::numeric_limits<float>::infinity ());
  __m256 z[4], nearest = inf;
  for (int i = 0; i < 4; ++i)
  {
    const __m256 valid = _mm256_and_ps (_mm256_cmp_ps (v[i][0], v[i][0], _CMP_ORD_Q), _mm256_cmp_ps (n[i][0], n[i][0], _CMP_ORD_Q));
    z[i] = _mm256_and_ps (v[i][2], valid);  // 0 where invalid
    nearest = _mm256_min_ps (nearest, _mm256_blendv_ps (inf, z[i], _mm256_cmp_ps (z[i], zero, _CMP_GT_OQ)));
  }
  const __m256 limit = _mm256_mul_ps (_mm256_set1_ps (max_jump), nearest);
  __m256 vs[3] = {zero, zero, zero}, ns[3] = {zero, zero, zero}, count = zero;
  for (int i = 0; i < 4; ++i)
  {
    const __m256 take = _mm256_and_ps (_mm256_cmp_ps (z[i], zero, _CMP_GT_OQ),
                                       _mm256_cmp_ps (_mm256_sub_ps (z[i], nearest), limit, _CMP_LE_OQ));
    for (int k = 0; k < 3; ++k)
    {
      vs[k] = _mm256_add_ps (vs[k], _mm256_and_ps (v[i][k], take));
      ns[k] = _mm256_add_ps (ns[k], _mm256_and_ps (n[i][k], take));
    }
    count = _mm256_add_ps (count, _mm256_and_ps (_mm256_set1_ps (1.f), take));
  }
  const __m256 norm = _mm256_sqrt_ps (_mm256_add_ps (_mm256_add_ps (_mm256_mul_ps (ns[0], ns[0]), _mm256_mul_ps (ns[1], ns[1])),
                                                     _mm256_mul_ps (ns[2], ns[2])));
  const __m256 ok = _mm256_and_ps (_mm256_cmp_ps (count, zero, _CMP_GT_OQ), _mm256_cmp_ps (norm, zero, _CMP_GT_OQ));
  const __m256 nan = _mm256_set1_ps (kNaN);
  __m256 vo[3], no[3];
  for (int k = 0; k < 3; ++k)
  {
    vo[k] = _mm256_blendv_ps (nan, _mm256_div_ps (vs[k], count), ok);
    no[k] = _mm256_blendv_ps (nan, _mm256_div_ps (ns[k], norm), ok);
  }
  avx2::storeXyz8 (v_out, vo[0], vo[1], vo[2]);
  avx2::storeXyz8 (n_out, no[0], no[1], no[2]);
}
#endif
}  // namespace

void
downsampleVertexNormalMaps (const cv::Mat& vertices, const cv::Mat& normals, cv::Mat& half_vertices,
                            cv::Mat& half_normals, float max_jump)
{
  half_vertices.create (vertices.rows / 2, vertices.cols / 2, CV_32FC3);
  half_normals.create (half_vertices.size (), CV_32FC3);
  [[maybe_unused]] const bool use_avx2 = vectorKernelsEnabled ();
  parallelForChunks (half_vertices.rows, 8, [&] (int, int begin, int end) {
    for (int y = begin; y < end; ++y)
    {
      int first = 0;  // the first column the scalar loop does
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
      // Eight output pixels at a time (the scalar loop was ~1 % of a whole run).
      if (use_avx2)
        for (; first + 8 <= half_vertices.cols; first += 8)
          downsampleVertexNormal8 (vertices.ptr<float> (2 * y) + 6 * first, vertices.ptr<float> (2 * y + 1) + 6 * first,
                                   normals.ptr<float> (2 * y) + 6 * first, normals.ptr<float> (2 * y + 1) + 6 * first, max_jump,
                                   half_vertices.ptr<float> (y) + 3 * first, half_normals.ptr<float> (y) + 3 * first);
#endif
      for (int x = first; x < half_vertices.cols; ++x)
      {
        const Eigen::Vector3f* v[4] = {&vertexAt (vertices, 2 * x, 2 * y), &vertexAt (vertices, 2 * x + 1, 2 * y),
                                       &vertexAt (vertices, 2 * x, 2 * y + 1), &vertexAt (vertices, 2 * x + 1, 2 * y + 1)};
        const Eigen::Vector3f* n[4] = {&vertexAt (normals, 2 * x, 2 * y), &vertexAt (normals, 2 * x + 1, 2 * y),
                                       &vertexAt (normals, 2 * x, 2 * y + 1), &vertexAt (normals, 2 * x + 1, 2 * y + 1)};
        float z[4];
        for (int i = 0; i < 4; ++i)
          z[i] = (isValidVertex (*v[i]) && isValidVertex (*n[i])) ? v[i]->z () : 0.f;
        const int mask = blockSelection (z, max_jump);
        Eigen::Vector3f vs = Eigen::Vector3f::Zero (), ns = Eigen::Vector3f::Zero ();
        for (int i = 0; i < 4; ++i)
          if (mask & (1 << i))
          {
            vs += *v[i];
            ns += *n[i];
          }
        // Written out (not ns.norm ()) so the eight-pixel kernel can sum in the same order.
        const float norm = std::sqrt ((ns.x () * ns.x () + ns.y () * ns.y ()) + ns.z () * ns.z ());
        if (mask == 0 || !(norm > 0.f))
        {
          half_vertices.at<cv::Vec3f> (y, x) = cv::Vec3f (kNaN, kNaN, kNaN);
          half_normals.at<cv::Vec3f> (y, x) = cv::Vec3f (kNaN, kNaN, kNaN);
          continue;
        }
        const float count = static_cast<float> (__builtin_popcount (static_cast<unsigned> (mask)));
        half_vertices.at<cv::Vec3f> (y, x) = cv::Vec3f (vs.x () / count, vs.y () / count, vs.z () / count);
        half_normals.at<cv::Vec3f> (y, x) = cv::Vec3f (ns.x () / norm, ns.y () / norm, ns.z () / norm);
      }
    }
  });
}

void
buildModelPyramid (const cv::Mat& vertices, const cv::Mat& normals, const PinholeCamera& camera, int levels,
                   float max_jump, FramePyramid& pyramid)
{
  pyramid.resize (static_cast<std::size_t> (levels));
  pyramid[0].camera = camera;
  pyramid[0].vertices = vertices;
  pyramid[0].normals = normals;
  for (std::size_t l = 1; l < pyramid.size (); ++l)
  {
    const PyramidLevel& finer = pyramid[l - 1];
    PyramidLevel& level = pyramid[l];
    downsampleVertexNormalMaps (finer.vertices, finer.normals, level.vertices, level.normals, max_jump);
    level.camera = finer.camera.scaled (level.vertices.cols, level.vertices.rows);
  }
}

void
BilateralFilterConfig::validate (const std::string& owner) const
{
  if (!enabled)
    return;
  if (!(diameter >= 1 && diameter <= 31))
    throw ParameterError (owner + ".diameter", "must lie in [1, 31] pixels");
  if (!(std::isfinite (sigma_space) && sigma_space > 0.0))
    throw ParameterError (owner + ".sigma_space", "must be positive");
  if (!(noise_range_sigma >= 0.0 && noise_range_sigma <= 100.0))
    throw ParameterError (owner + ".noise_range_sigma", "must lie in [0, 100] noise units (0 = fixed range sigma)");
  if (noise_range_sigma == 0.0 && !(std::isfinite (range_sigma_metres) && range_sigma_metres > 0.0))
    throw ParameterError (owner + ".range_sigma_metres", "must be positive");
}

void
bilateralFilterDepth (const cv::Mat& depth, const BilateralFilterConfig& config, cv::Mat& filtered)
{
  CV_Assert (depth.type () == CV_32F);
  if (config.enabled && config.noise_range_sigma > 0.0)
  {
    noiseAdaptiveBilateral (depth, config.diameter, static_cast<float> (config.noise_range_sigma),
                            static_cast<float> (config.sigma_space), filtered);  // invalid pixels come out 0
    return;
  }
  // 0 for invalid (NaN too): the range kernel then gives them no weight next to a
  // surface (|0 − z| ≫ σ), and they are masked again after the filter.
  const cv::Mat valid = depth > 0.f;  // false for NaN
  cv::Mat clean = cv::Mat::zeros (depth.size (), CV_32F);
  depth.copyTo (clean, valid);
  if (!config.enabled)
  {
    filtered = clean;
    return;
  }
  cv::bilateralFilter (clean, filtered, config.diameter, config.range_sigma_metres, config.sigma_space);
  filtered.setTo (0.f, ~valid);
}

void
DepthPreprocessorConfig::validate () const
{
  bilateral.validate ("DepthPreprocessorConfig::bilateral");
  if (!(pyramid_levels >= 1 && pyramid_levels <= 6))
    throw ParameterError ("DepthPreprocessorConfig::pyramid_levels", "must lie in [1, 6]");
  if (!(min_depth >= 0.0 && max_depth > min_depth))
    throw ParameterError ("DepthPreprocessorConfig::max_depth", "depth range must satisfy 0 <= min < max");
  if (!(max_depth_jump > 0.0))
    throw ParameterError ("DepthPreprocessorConfig::max_depth_jump", "must be positive");
  normals.validate ("DepthPreprocessorConfig::normals");
  if (normals_min_width < 0)
    throw ParameterError ("DepthPreprocessorConfig::normals_min_width", "must not be negative");
}

DepthPreprocessor::DepthPreprocessor (const DepthPreprocessorConfig& config) : config_ (config)
{
  config_.validate ();
}

void
DepthPreprocessor::compute (const cv::Mat& depth, const PinholeCamera& camera, FramePyramid& pyramid) const
{
  if (depth.type () != CV_32F || depth.cols != camera.width || depth.rows != camera.height)
    throw Error ("DepthPreprocessor", "depth must be CV_32F of the camera's image size");
  const float lo = static_cast<float> (config_.min_depth), hi = static_cast<float> (config_.max_depth);
  const float jump = static_cast<float> (config_.max_depth_jump);
  pyramid.resize (static_cast<std::size_t> (config_.pyramid_levels));

  // Invalid and out-of-range samples become 0; the bilateral filter's range kernel then
  // gives them no weight next to real surfaces (|0 − z| ≫ σ), and they are masked again
  // afterwards so the filter cannot invent depth in holes.
  cv::Mat clean (depth.size (), CV_32F);
  parallelForChunks (depth.rows, 16, [&] (int, int begin, int end) {
    for (int v = begin; v < end; ++v)
    {
      const float* in = depth.ptr<float> (v);
      float* out = clean.ptr<float> (v);
      for (int u = 0; u < depth.cols; ++u)
        out[u] = (in[u] >= lo && in[u] <= hi) ? in[u] : 0.f;
    }
  });
  PyramidLevel& base = pyramid[0];
  base.camera = camera;
  bilateralFilterDepth (clean, config_.bilateral, base.depth);  // holes stay 0

  for (std::size_t l = 0; l < pyramid.size (); ++l)
  {
    PyramidLevel& level = pyramid[l];
    if (l > 0)
    {
      downsampleDepth (pyramid[l - 1].depth, level.depth, jump);
      level.camera = pyramid[l - 1].camera.scaled (level.depth.cols, level.depth.rows);
    }
    computeVertexMap (level.depth, level.camera, level.vertices);
    computeNormalMap (level.vertices, level.normals, l == 0 ? config_.levelZeroNormals (depth.cols) : NormalMapConfig{1, jump});
  }
}
}  // namespace reconstruction
}  // namespace cuefusion
