#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/projective_icp.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <Eigen/Cholesky>

#include <array>
#include <cmath>


namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** \brief Upper triangle of J^T J (21), J^T r (6), Σ r², the pair count and the number
  * of valid source points.
  */
using Accumulator = std::array<double, 30>;
/** \brief The same for one image row, in float (cheap; a row holds < 10^4 terms). */
using RowAccumulator = std::array<float, 30>;

/** \brief Projective association of one source vertex; on success the point-to-plane
  * residual r = n·(p' − q) and its Jacobian row J = [(p' × n)^T, n^T] for a left update.
  */
inline bool
pointToPlaneTerm (const Eigen::Vector3f& p, const Eigen::Vector3f& n_src, const Eigen::Matrix3f& R,
                  const Eigen::Vector3f& t, const PyramidLevel& target, float max_distance_sq, float min_cos,
                  float& residual, Eigen::Matrix<float, 6, 1>& J)
{
  const Eigen::Vector3f p_t = R * p + t;
  int u, v;
  if (!target.camera.projectToPixel (p_t, u, v))
    return false;
  const Eigen::Vector3f& q = vertexAt (target.vertices, u, v);
  const Eigen::Vector3f& n = vertexAt (target.normals, u, v);
  if (!isValidVertex (q) || !isValidVertex (n))
    return false;
  const Eigen::Vector3f diff = p_t - q;
  if (diff.squaredNorm () > max_distance_sq)
    return false;
  if ((R * n_src).dot (n) < min_cos)
    return false;
  residual = n.dot (diff);
  J.head<3> () = p_t.cross (n);
  J.tail<3> () = n;
  return true;
}

inline void
accumulate (RowAccumulator& acc, const Eigen::Matrix<float, 6, 1>& J, float r)
{
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j)
      acc[static_cast<std::size_t> (k++)] += J[i] * J[j];
  for (int i = 0; i < 6; ++i)
    acc[static_cast<std::size_t> (21 + i)] += J[i] * r;
  acc[27] += r * r;
  acc[28] += 1.f;
}

/** \brief One association + accumulation pass over a level. */
Accumulator
buildSystem (const PyramidLevel& source, const PyramidLevel& target, const Eigen::Isometry3f& T, float max_distance,
             float min_cos)
{
  const Eigen::Matrix3f R = T.linear ();
  const Eigen::Vector3f t = T.translation ();
  const float max_distance_sq = max_distance * max_distance;
  // Partial sums per fixed chunk of rows, added in chunk order: the same total on every run.
  constexpr int kRowsPerChunk = 8;
  std::vector<Accumulator> partial (static_cast<std::size_t> (chunkCount (source.vertices.rows, kRowsPerChunk)), Accumulator{});
  parallelForChunks (source.vertices.rows, kRowsPerChunk, [&] (int k, int begin, int end) {
    Accumulator& local = partial[static_cast<std::size_t> (k)];
    for (int y = begin; y < end; ++y)
    {
      RowAccumulator row{};
      for (int x = 0; x < source.vertices.cols; ++x)
      {
        const Eigen::Vector3f& p = vertexAt (source.vertices, x, y);
        const Eigen::Vector3f& n = vertexAt (source.normals, x, y);
        if (!isValidVertex (p) || !isValidVertex (n))
          continue;
        row[29] += 1.f;
        float r;
        Eigen::Matrix<float, 6, 1> J;
        if (pointToPlaneTerm (p, n, R, t, target, max_distance_sq, min_cos, r, J))
          accumulate (row, J, r);
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

void
ProjectiveICPConfig::validate () const
{
  if (iterations.empty () || iterations.size () > 6)
    throw ParameterError ("icp.iterations", "needs one to six pyramid levels");
  for (const int n : iterations)
    if (n < 0 || n > 100)
      throw ParameterError ("icp.iterations", "must lie in [0, 100] per level");
  if (!(max_distance > 0.0))
    throw ParameterError ("icp.max_distance", "must be positive");
  if (!(max_angle_deg > 0.0 && max_angle_deg <= 180.0))
    throw ParameterError ("icp.max_angle", "must lie in (0, 180] degrees");
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
  const float min_cos = static_cast<float> (std::cos (config_.max_angle_deg * M_PI / 180.0));
  bool finest_measured = false;
  for (std::size_t l = levels; l-- > 0;)
  {
    for (int it = 0; it < config_.iterations[l]; ++it)
    {
      const Accumulator acc = buildSystem (source[l], target[l], result.transform.cast<float> (),
                                           static_cast<float> (config_.max_distance), min_cos);
      if (l == 0)
      {
        finest_measured = true;
        result.source_points = static_cast<std::size_t> (acc[29]);
        result.inliers = static_cast<std::size_t> (acc[28]);
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
  // Inliers and RMS come from the last finest-level pass (before its final, small
  // update); a separate pass just for them would cost another full-resolution sweep.
  if (!finest_measured)
  {
    const Accumulator acc = buildSystem (source[0], target[0], result.transform.cast<float> (),
                                         static_cast<float> (config_.max_distance), min_cos);
    result.source_points = static_cast<std::size_t> (acc[29]);
    result.inliers = static_cast<std::size_t> (acc[28]);
    result.rmse = acc[28] > 0 ? std::sqrt (acc[27] / acc[28]) : 0.0;
  }
  // Re-orthonormalise: many small left updates drift off SO(3) in floating point.
  const Eigen::Quaterniond q (result.transform.rotation ());
  result.transform.linear () = q.normalized ().toRotationMatrix ();
  return result;
}
}  // namespace reconstruction
}  // namespace cuefusion
