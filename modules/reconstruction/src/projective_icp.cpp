// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/projective_icp.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>



namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** \brief Upper triangle of J^T J (21), J^T r (6), Σ r², the pair count, the number of
  * valid source points and the number of those associated with a valid model point
  * (before the distance and normal gates).
  */
using Accumulator = std::array<double, 31>;
/** \brief The same for one image row, in float (cheap; a row holds < 10^4 terms). */
using RowAccumulator = std::array<float, 31>;

/** \brief Weight of a term at model depth \a z: the inverse variance of the axial noise
  * there, relative to a point at 1 m (1 when \a weighted is false).
  */
inline float
noiseWeight (float z, bool weighted)
{
  if (!weighted)
    return 1.f;
  const float ratio = KinectNoiseModel::atNormalIncidence (1.f) / KinectNoiseModel::atNormalIncidence (z);
  return ratio * ratio;
}

/** \brief Projective association of one source vertex; on success the point-to-plane
  * residual r = n·(p' − q) and its Jacobian row J = [(p' × n)^T, n^T] for a left update,
  * and its noiseWeight. \a associated: it projected onto a valid model point (gated or not).
  */
inline bool
pointToPlaneTerm (const Eigen::Vector3f& p, const Eigen::Vector3f& n_src, const Eigen::Matrix3f& R,
                  const Eigen::Vector3f& t, const PyramidLevel& target, float max_distance_sq, float min_cos,
                  bool weighted, float& residual, Eigen::Matrix<float, 6, 1>& J, float& weight, bool& associated)
{
  associated = false;
  const Eigen::Vector3f p_t = R * p + t;
  int u, v;
  if (!target.camera.projectToPixel (p_t, u, v))
    return false;
  const Eigen::Vector3f& q = vertexAt (target.vertices, u, v);
  const Eigen::Vector3f& n = vertexAt (target.normals, u, v);
  if (!isValidVertex (q) || !isValidVertex (n))
    return false;
  associated = true;
  const Eigen::Vector3f diff = p_t - q;
  if (diff.squaredNorm () > max_distance_sq)
    return false;
  if ((R * n_src).dot (n) < min_cos)
    return false;
  residual = n.dot (diff);
  J.head<3> () = p_t.cross (n);
  J.tail<3> () = n;
  weight = noiseWeight (q.z (), weighted);
  return true;
}

/** \brief Adds a term: the weighted normal equations (w JᵀJ, w Jᵀr), the unweighted r²
  * (the reported RMS is in metres) and the inlier count.
  */
inline void
accumulate (RowAccumulator& acc, const Eigen::Matrix<float, 6, 1>& J, float r, float w)
{
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j)
      acc[static_cast<std::size_t> (k++)] += w * J[i] * J[j];
  for (int i = 0; i < 6; ++i)
    acc[static_cast<std::size_t> (21 + i)] += w * J[i] * r;
  acc[27] += r * r;
  acc[28] += 1.f;
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
/** \brief pointToPlaneTerm + accumulate for the pixels [0, 8·⌊cols/8⌋) of row \a y, eight
  * at a time with AVX2; returns the first pixel left for the scalar loop. Per lane the
  * same tests and the same terms as the scalar code (projection in float instead of
  * PinholeCamera's double, so a point on a pixel border may associate with the
  * neighbour); rejected lanes add exact zeros. Measured on icl-livingroom1: tracking
  * 9 → 5.5 ms per frame (2 cores).
  */
CUEFUSION_AVX2 int
accumulateRowAvx2 (const PyramidLevel& source, const PyramidLevel& target, int y, const Eigen::Matrix3f& R,
                   const Eigen::Vector3f& t, float max_distance_sq, float min_cos, bool weighted, RowAccumulator& row)
{
  const int cols = source.vertices.cols;
  const int end = cols - cols % 8;
  if (end == 0)
    return 0;
  const float* src_v = source.vertices.ptr<float> (y);
  const float* src_n = source.normals.ptr<float> (y);
  const float* tgt_v = target.vertices.ptr<float> ();
  const float* tgt_n = target.normals.ptr<float> ();
  const __m256i target_step = _mm256_set1_epi32 (static_cast<int> (target.vertices.step1 ()));
  const __m256i normal_step = _mm256_set1_epi32 (static_cast<int> (target.normals.step1 ()));
  const __m256i three = _mm256_set1_epi32 (3);
  __m256 r00 = _mm256_set1_ps (R (0, 0)), r01 = _mm256_set1_ps (R (0, 1)), r02 = _mm256_set1_ps (R (0, 2));
  __m256 r10 = _mm256_set1_ps (R (1, 0)), r11 = _mm256_set1_ps (R (1, 1)), r12 = _mm256_set1_ps (R (1, 2));
  __m256 r20 = _mm256_set1_ps (R (2, 0)), r21 = _mm256_set1_ps (R (2, 1)), r22 = _mm256_set1_ps (R (2, 2));
  const __m256 tx = _mm256_set1_ps (t.x ()), ty = _mm256_set1_ps (t.y ()), tz = _mm256_set1_ps (t.z ());
  const __m256 fx = _mm256_set1_ps (static_cast<float> (target.camera.fx));
  const __m256 fy = _mm256_set1_ps (static_cast<float> (target.camera.fy));
  const __m256 cx = _mm256_set1_ps (static_cast<float> (target.camera.cx));
  const __m256 cy = _mm256_set1_ps (static_cast<float> (target.camera.cy));
  const __m256 width = _mm256_set1_ps (static_cast<float> (target.camera.width));
  const __m256 height = _mm256_set1_ps (static_cast<float> (target.camera.height));
  const __m256 minus_one = _mm256_set1_ps (-1.f), zero = _mm256_setzero_ps (), half = _mm256_set1_ps (0.5f);
  const __m256 max_sq = _mm256_set1_ps (max_distance_sq), cos_limit = _mm256_set1_ps (min_cos);
  const __m256 noise_at_one = _mm256_set1_ps (KinectNoiseModel::atNormalIncidence (1.f)), one = _mm256_set1_ps (1.f);

  __m256 acc[28];
  for (__m256& a : acc)
    a = zero;
  int source_points = 0;
  for (int x = 0; x < end; x += 8)
  {
    __m256 px, py, pz, nx, ny, nz;
    avx2::loadXyz8 (src_v + 3 * x, px, py, pz);
    avx2::loadXyz8 (src_n + 3 * x, nx, ny, nz);
    const __m256 valid_source = _mm256_and_ps (_mm256_cmp_ps (px, px, _CMP_ORD_Q), _mm256_cmp_ps (nx, nx, _CMP_ORD_Q));
    const int source_mask = _mm256_movemask_ps (valid_source);
    if (source_mask == 0)
      continue;
    source_points += __builtin_popcount (static_cast<unsigned> (source_mask));
    // p' = R p + t, R n
    const __m256 qx = _mm256_fmadd_ps (r00, px, _mm256_fmadd_ps (r01, py, _mm256_fmadd_ps (r02, pz, tx)));
    const __m256 qy = _mm256_fmadd_ps (r10, px, _mm256_fmadd_ps (r11, py, _mm256_fmadd_ps (r12, pz, ty)));
    const __m256 qz = _mm256_fmadd_ps (r20, px, _mm256_fmadd_ps (r21, py, _mm256_fmadd_ps (r22, pz, tz)));
    const __m256 mx = _mm256_fmadd_ps (r00, nx, _mm256_fmadd_ps (r01, ny, _mm256_mul_ps (r02, nz)));
    const __m256 my = _mm256_fmadd_ps (r10, nx, _mm256_fmadd_ps (r11, ny, _mm256_mul_ps (r12, nz)));
    const __m256 mz = _mm256_fmadd_ps (r20, nx, _mm256_fmadd_ps (r21, ny, _mm256_mul_ps (r22, nz)));
    // Projective association: nearest pixel of p' in the target.
    const __m256 uf = _mm256_add_ps (_mm256_div_ps (_mm256_mul_ps (fx, qx), qz), cx);
    const __m256 vf = _mm256_add_ps (_mm256_div_ps (_mm256_mul_ps (fy, qy), qz), cy);
    __m256 ok = _mm256_and_ps (valid_source, _mm256_cmp_ps (qz, zero, _CMP_GT_OQ));
    ok = _mm256_and_ps (ok, _mm256_and_ps (_mm256_cmp_ps (uf, minus_one, _CMP_GT_OQ), _mm256_cmp_ps (vf, minus_one, _CMP_GT_OQ)));
    ok = _mm256_and_ps (ok, _mm256_and_ps (_mm256_cmp_ps (uf, width, _CMP_LT_OQ), _mm256_cmp_ps (vf, height, _CMP_LT_OQ)));
    // Lanes already rejected convert garbage; they read pixel (0, 0) below and are masked out.
    const __m256i u = _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (_mm256_and_ps (uf, ok), half)));
    const __m256i v = _mm256_cvttps_epi32 (_mm256_floor_ps (_mm256_add_ps (_mm256_and_ps (vf, ok), half)));
    ok = _mm256_and_ps (ok, _mm256_castsi256_ps (avx2::insideImage (u, v, target.camera.width, target.camera.height)));
    if (_mm256_movemask_ps (ok) == 0)
      continue;
    const __m256i inside = _mm256_castps_si256 (ok);
    const __m256i u3 = _mm256_mullo_epi32 (_mm256_and_si256 (u, inside), three);
    const __m256i v_inside = _mm256_and_si256 (v, inside);
    alignas (32) std::int32_t vertex_offsets[8], normal_offsets[8];
    _mm256_store_si256 (reinterpret_cast<__m256i*> (vertex_offsets), _mm256_add_epi32 (_mm256_mullo_epi32 (v_inside, target_step), u3));
    _mm256_store_si256 (reinterpret_cast<__m256i*> (normal_offsets), _mm256_add_epi32 (_mm256_mullo_epi32 (v_inside, normal_step), u3));
    __m256 gx, gy, gz, hx, hy, hz;
    avx2::gatherXyz8 (tgt_v, vertex_offsets, gx, gy, gz);
    avx2::gatherXyz8 (tgt_n, normal_offsets, hx, hy, hz);
    ok = _mm256_and_ps (ok, _mm256_and_ps (_mm256_cmp_ps (gx, gx, _CMP_ORD_Q), _mm256_cmp_ps (hx, hx, _CMP_ORD_Q)));
    row[30] += static_cast<float> (__builtin_popcount (static_cast<unsigned> (_mm256_movemask_ps (ok))));
    const __m256 dx = _mm256_sub_ps (qx, gx), dy = _mm256_sub_ps (qy, gy), dz = _mm256_sub_ps (qz, gz);
    const __m256 dist_sq = _mm256_fmadd_ps (dx, dx, _mm256_fmadd_ps (dy, dy, _mm256_mul_ps (dz, dz)));
    const __m256 cos_angle = _mm256_fmadd_ps (mx, hx, _mm256_fmadd_ps (my, hy, _mm256_mul_ps (mz, hz)));
    ok = _mm256_and_ps (ok, _mm256_and_ps (_mm256_cmp_ps (dist_sq, max_sq, _CMP_LE_OQ),
                                           _mm256_cmp_ps (cos_angle, cos_limit, _CMP_GE_OQ)));
    if (_mm256_movemask_ps (ok) == 0)
      continue;
    // Rejected lanes are set to exact zeros (masking, not multiplying: they may hold NaN),
    // so they add nothing.
    const __m256 n0 = _mm256_and_ps (hx, ok), n1 = _mm256_and_ps (hy, ok), n2 = _mm256_and_ps (hz, ok);
    const __m256 res = _mm256_and_ps (_mm256_fmadd_ps (n0, dx, _mm256_fmadd_ps (n1, dy, _mm256_mul_ps (n2, dz))), ok);
    __m256 J[6];
    J[0] = _mm256_and_ps (_mm256_fmsub_ps (qy, n2, _mm256_mul_ps (qz, n1)), ok);
    J[1] = _mm256_and_ps (_mm256_fmsub_ps (qz, n0, _mm256_mul_ps (qx, n2)), ok);
    J[2] = _mm256_and_ps (_mm256_fmsub_ps (qx, n1, _mm256_mul_ps (qy, n0)), ok);
    J[3] = n0;
    J[4] = n1;
    J[5] = n2;
    // noiseWeight at the model point's depth, masked (a rejected lane's depth may be NaN).
    __m256 weight = one;
    if (weighted)
    {
      const __m256 ratio = _mm256_div_ps (noise_at_one, avx2::kinectNoiseAtNormalIncidence (gz));
      weight = _mm256_mul_ps (ratio, ratio);
    }
    weight = _mm256_and_ps (weight, ok);
    __m256 wJ[6];
    for (int i = 0; i < 6; ++i)
      wJ[i] = _mm256_mul_ps (weight, J[i]);
    int k = 0;
    for (int i = 0; i < 6; ++i)
      for (int j = i; j < 6; ++j, ++k)
        acc[k] = _mm256_fmadd_ps (wJ[i], J[j], acc[k]);
    for (int i = 0; i < 6; ++i)
      acc[21 + i] = _mm256_fmadd_ps (wJ[i], res, acc[21 + i]);
    acc[27] = _mm256_fmadd_ps (res, res, acc[27]);
    row[28] += static_cast<float> (__builtin_popcount (static_cast<unsigned> (_mm256_movemask_ps (ok))));
  }
  alignas (32) float lanes[8];
  for (int k = 0; k < 28; ++k)
  {
    _mm256_store_ps (lanes, acc[k]);
    row[static_cast<std::size_t> (k)] += ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]));
  }
  row[29] += static_cast<float> (source_points);
  return end;
}
#endif

/** \brief One association + accumulation pass over a level. */
Accumulator
buildSystem (const PyramidLevel& source, const PyramidLevel& target, const Eigen::Isometry3f& T, float max_distance,
             float min_cos, bool weighted)
{
  const Eigen::Matrix3f R = T.linear ();
  const Eigen::Vector3f t = T.translation ();
  const float max_distance_sq = max_distance * max_distance;
  const bool use_avx2 = vectorKernelsEnabled ();
  // Partial sums per fixed chunk of rows, added in chunk order: the same total on every run.
  constexpr int kRowsPerChunk = 8;
  std::vector<Accumulator> partial (static_cast<std::size_t> (chunkCount (source.vertices.rows, kRowsPerChunk)), Accumulator{});
  parallelForChunks (source.vertices.rows, kRowsPerChunk, [&] (int k, int begin, int end) {
    Accumulator& local = partial[static_cast<std::size_t> (k)];
    for (int y = begin; y < end; ++y)
    {
      RowAccumulator row{};
      int x = 0;
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
      if (use_avx2)
        x = accumulateRowAvx2 (source, target, y, R, t, max_distance_sq, min_cos, weighted, row);
#endif
      for (; x < source.vertices.cols; ++x)
      {
        const Eigen::Vector3f& p = vertexAt (source.vertices, x, y);
        const Eigen::Vector3f& n = vertexAt (source.normals, x, y);
        if (!isValidVertex (p) || !isValidVertex (n))
          continue;
        row[29] += 1.f;
        float r, w;
        Eigen::Matrix<float, 6, 1> J;
        bool associated = false;
        if (pointToPlaneTerm (p, n, R, t, target, max_distance_sq, min_cos, weighted, r, J, w, associated))
          accumulate (row, J, r, w);
        row[30] += associated ? 1.f : 0.f;
      }
      for (std::size_t i = 0; i < local.size (); ++i)
        local[i] += static_cast<double> (row[i]);
    }
  });
  Accumulator total{};
  for (const Accumulator& local : partial)
    for (std::size_t i = 0; i < total.size (); ++i)
      total[i] += local[i];
  return total;
}

/** \brief λ_min / λ_max of the translation block Σ w n nᵀ of the normal equations \a A:
  * how evenly the matched normals span the three directions (0: all parallel, a plane).
  */
double
translationConditioning (const Eigen::Matrix<double, 6, 6>& A)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen (A.bottomRightCorner<3, 3> (), Eigen::EigenvaluesOnly);
  const Eigen::Vector3d values = eigen.eigenvalues ();
  return values[2] > 0.0 ? std::max (0.0, values[0]) / values[2] : 0.0;
}

/** \brief exp of a twist (ω, t) as a rigid motion (rotation by |ω| about ω; first-order
  * translation, enough for the small ICP steps).
  */
Eigen::Isometry3d
twistToIsometry (const Eigen::Matrix<double, 6, 1>& xi)
{
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity ();
  const Eigen::Vector3d w = xi.head<3> ();
  const double angle = w.norm ();
  if (angle > 0.0)
    T.linear () = Eigen::AngleAxisd (angle, w / angle).toRotationMatrix ();
  T.translation () = xi.tail<3> ();
  return T;
}
}  // namespace

double
normalGateDeg (const ProjectiveICPConfig& config, double median_depth)
{
  const double z_ref = config.angle_reference_depth;
  if (!(z_ref > 0.0))
    return config.max_angle_deg;
  const auto relative_noise = [] (double z) { return KinectNoiseModel::atNormalIncidence (static_cast<float> (z)) / z; };
  const double depth_ratio = median_depth > z_ref ? relative_noise (median_depth) / relative_noise (z_ref) : 1.0;
  const double ratio = config.noise_scale * depth_ratio;
  return ratio > 1.0 ? std::min (config.max_angle_limit_deg, config.max_angle_deg * ratio) : config.max_angle_deg;
}

double
ownTranslationConditioning (const PyramidLevel& level, bool noise_weighting)
{
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero ();
  for (int y = 0; y < level.vertices.rows; ++y)
    for (int x = 0; x < level.vertices.cols; ++x)
    {
      const Eigen::Vector3f& p = vertexAt (level.vertices, x, y);
      const Eigen::Vector3f& n = vertexAt (level.normals, x, y);
      if (isValidVertex (p) && isValidVertex (n))
        sum += static_cast<double> (noiseWeight (p.z (), noise_weighting)) * (n.cast<double> () * n.cast<double> ().transpose ());
    }
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero ();
  A.bottomRightCorner<3, 3> () = sum;
  return translationConditioning (A);
}

void
ProjectiveICPConfig::validate () const
{
  if (iterations.empty () || iterations.size () > 6)
    throw ParameterError ("ProjectiveICPConfig::iterations", "needs one to six pyramid levels");
  for (const int n : iterations)
    if (n < 0 || n > 100)
      throw ParameterError ("ProjectiveICPConfig::iterations", "must lie in [0, 100] per level");
  if (!(max_distance > 0.0))
    throw ParameterError ("ProjectiveICPConfig::max_distance", "must be positive");
  if (!(max_angle_deg > 0.0 && max_angle_deg <= 180.0))
    throw ParameterError ("ProjectiveICPConfig::max_angle_deg", "must lie in (0, 180] degrees");
  if (!(max_angle_limit_deg >= max_angle_deg && max_angle_limit_deg <= 180.0))
    throw ParameterError ("ProjectiveICPConfig::max_angle_limit_deg", "must lie in [max_angle_deg, 180] degrees");
  if (!(angle_reference_depth >= 0.0 && angle_reference_depth <= 20.0))
    throw ParameterError ("ProjectiveICPConfig::angle_reference_depth", "must lie in [0, 20] metres");
  if (!(noise_scale > 0.0 && noise_scale <= 100.0))
    throw ParameterError ("ProjectiveICPConfig::noise_scale", "must lie in (0, 100] (the depth's noise over the Kinect model's)");
}

ProjectiveICP::ProjectiveICP (const ProjectiveICPConfig& config) : config_ (config)
{
  config_.validate ();
}

ICPResult
ProjectiveICP::align (const FramePyramid& source, const FramePyramid& target, const Eigen::Isometry3d& guess) const
{
  const std::size_t levels = config_.iterations.size ();
  if (source.size () < levels || target.size () < levels)
    throw Error ("ProjectiveICP", "pyramids have fewer levels than iterations are configured for");
  ICPResult result;
  result.transform = guess;
  result.solved = true;
  // The frame's median depth (coarsest level: a sixteenth of the points) sets the normal gate.
  std::vector<float> depths;
  const PyramidLevel& coarsest = source[levels - 1];
  depths.reserve (coarsest.vertices.total ());
  for (int y = 0; y < coarsest.vertices.rows; ++y)
    for (int x = 0; x < coarsest.vertices.cols; ++x)
    {
      const Eigen::Vector3f& p = vertexAt (coarsest.vertices, x, y);
      if (isValidVertex (p))
        depths.push_back (p.z ());
    }
  double median_depth = 0.0;
  if (!depths.empty ())
  {
    std::nth_element (depths.begin (), depths.begin () + static_cast<long> (depths.size () / 2), depths.end ());
    median_depth = depths[depths.size () / 2];
  }
  result.normal_gate_deg = normalGateDeg (config_, median_depth);
  const float min_cos = static_cast<float> (std::cos (result.normal_gate_deg * M_PI / 180.0));
  bool finest_measured = false;
  Eigen::Matrix<double, 6, 6> coarsest_system = Eigen::Matrix<double, 6, 6>::Zero ();  // its last iteration's
  for (std::size_t l = levels; l-- > 0;)
  {
    for (int it = 0; it < config_.iterations[l]; ++it)
    {
      const Accumulator acc = buildSystem (source[l], target[l], result.transform.cast<float> (),
                                           static_cast<float> (config_.max_distance), min_cos, config_.noise_weighting);
      if (l == 0)
      {
        finest_measured = true;
        result.source_points = static_cast<std::size_t> (acc[29]);
        result.inliers = static_cast<std::size_t> (acc[28]);
        result.associated = static_cast<std::size_t> (acc[30]);
        result.rmse = acc[28] > 0 ? std::sqrt (acc[27] / acc[28]) : 0.0;
      }
      if (acc[28] < 6)
      {
        result.solved = false;
        break;
      }
      Eigen::Matrix<double, 6, 6> A;
      Eigen::Matrix<double, 6, 1> b;
      int k = 0;
      for (int i = 0; i < 6; ++i)
        for (int j = i; j < 6; ++j)
          A (i, j) = A (j, i) = acc[static_cast<std::size_t> (k++)];
      for (int i = 0; i < 6; ++i)
        b[i] = -acc[static_cast<std::size_t> (21 + i)];
      if (l == levels - 1)  // coarsest: normals averaged over 4×4 pixels, their noise fakes no constraint
        coarsest_system = A;
      const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt (A);
      if (ldlt.info () != Eigen::Success || !ldlt.isPositive () ||
          ldlt.vectorD ().minCoeff () <= 1e-9 * ldlt.vectorD ().maxCoeff ())
      {
        result.solved = false;
        break;
      }
      const Eigen::Matrix<double, 6, 1> xi = ldlt.solve (b);
      if (!xi.allFinite ())
      {
        result.solved = false;
        break;
      }
      result.transform = twistToIsometry (xi) * result.transform;
      ++result.iterations;
      if (xi.head<3> ().norm () < config_.convergence_rotation && xi.tail<3> ().norm () < config_.convergence_translation)
        break;
    }
  }
  result.translation_conditioning = translationConditioning (coarsest_system);
  // Inliers and RMS come from the last finest-level pass (before its final, small
  // update); a separate pass just for them would cost another full-resolution sweep.
  if (!finest_measured)
  {
    const Accumulator acc = buildSystem (source[0], target[0], result.transform.cast<float> (),
                                         static_cast<float> (config_.max_distance), min_cos, config_.noise_weighting);
    result.source_points = static_cast<std::size_t> (acc[29]);
    result.inliers = static_cast<std::size_t> (acc[28]);
    result.associated = static_cast<std::size_t> (acc[30]);
    result.rmse = acc[28] > 0 ? std::sqrt (acc[27] / acc[28]) : 0.0;
  }
  // Re-orthonormalise: many small left updates drift off SO(3) in floating point.
  const Eigen::Quaterniond q (result.transform.rotation ());
  result.transform.linear () = q.normalized ().toRotationMatrix ();
  return result;
}
}  // namespace reconstruction
}  // namespace cuefusion
