// The per-direction loops of the §4.2.1.1 edge operators over SurfacePlanes. Each pass
// compares every pixel with its neighbour at one offset (dx, dy); the inner loop over x
// reads contiguous floats and is vectorised by the compiler. NaN does the bookkeeping:
// a term involving a missing point or normal is NaN, and std::min/std::max(a, NaN) keep a.
// The two hot loops are also built for AVX2 (target_clones: the loader picks the clone
// for the CPU, whatever setVectorKernelsEnabled says; AVX2 without FMA, so both clones
// compute the same bits). Measured on icl-livingroom1: geometric segmentation 5.8 → 4.7
// ms a frame.
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <algorithm>
#include <array>
#include <vector>

// target_clones makes an ifunc whose resolver runs while the program is loaded, before
// ThreadSanitizer's runtime is ready (a TSan build crashes at start-up): no clones there.
#if defined(__SANITIZE_THREAD__)
#define CUEFUSION_AVX2_CLONES
#else
#define CUEFUSION_AVX2_CLONES __attribute__ ((target_clones ("avx2", "default")))
#endif

namespace cuefusion
{
namespace segmentation
{
namespace
{
std::array<std::array<int, 2>, 8>
offsets (int step)
{
  return {{{{-step, -step}}, {{0, -step}}, {{step, -step}}, {{-step, 0}}, {{step, 0}}, {{-step, step}}, {{0, step}}, {{step, step}}}};
}

constexpr int kPhi = 1, kGamma = 2;

/** One neighbour direction (dx, dy) for row y: updates Φ (min of Φ_i) and/or Γ (max of
  * Γ_i) of every pixel of the row, as \a kWhich says. Both operators read the same
  * points and normals, so GeometricSegmentation runs them in one pass.
  */
template <int kWhich, bool kSymmetric>
CUEFUSION_AVX2_CLONES void
edgeRowPass (const SurfacePlanes& p, int y, int dx, int dy, float* __restrict phi, float* __restrict gamma)
{
  const int w = p.width;
  const int x0 = std::max (0, -dx), x1 = std::min (w, w - dx);
  const std::size_t a = static_cast<std::size_t> (y) * w, b = static_cast<std::size_t> (y + dy) * w + dx;
  const float* __restrict X = p.x.data () + a;
  const float* __restrict Y = p.y.data () + a;
  const float* __restrict Z = p.z.data () + a;
  const float* __restrict NX = p.nx.data () + a;
  const float* __restrict NY = p.ny.data () + a;
  const float* __restrict NZ = p.nz.data () + a;
  const float* __restrict Xi = p.x.data () + b;
  const float* __restrict Yi = p.y.data () + b;
  const float* __restrict Zi = p.z.data () + b;
  const float* __restrict NXi = p.nx.data () + b;
  const float* __restrict NYi = p.ny.data () + b;
  const float* __restrict NZi = p.nz.data () + b;
  const float inf = std::numeric_limits<float>::infinity ();
  for (int x = x0; x < x1; ++x)
  {
    const float ex = Xi[x] - X[x], ey = Yi[x] - Y[x], ez = Zi[x] - Z[x];
    const float offset = ex * NX[x] + ey * NY[x] + ez * NZ[x];  // (v_i − v)·n
    if constexpr ((kWhich & kPhi) != 0)
    {
      // Same tests as concavityTerm / concavityTermSymmetric (edge_operators.h), spelled
      // out on plain floats so that the loop vectorises.
      const float agreement = NX[x] * NXi[x] + NY[x] * NYi[x] + NZ[x] * NZi[x];
      const float convexity = kSymmetric ? (NXi[x] - NX[x]) * ex + (NYi[x] - NY[x]) * ey + (NZi[x] - NZ[x]) * ez : -offset;
      const bool convex = kSymmetric ? convexity >= 0.f : convexity > 0.f;
      const float term = convex ? 1.f : agreement;  // NaN when either side lacks a point or normal
      phi[x] = std::min (phi[x], term);
    }
    if constexpr ((kWhich & kGamma) != 0)
    {
      const float term = (Zi[x] != Zi[x]) ? inf : std::abs (offset);  // a missing neighbour is an edge
      gamma[x] = std::max (gamma[x], term);
    }
  }
}

/** All 8 directions at \a step for row y, then the rows' final values (see the map
  * functions below). \a phi or \a gamma may be null.
  */
template <int kWhich>
void
edgeRow (const SurfacePlanes& planes, int y, int step, ConvexityTest test, float* phi, float* gamma)
{
  const int w = planes.width, h = planes.height;
  if constexpr ((kWhich & kPhi) != 0)
    std::fill (phi, phi + w, 1.f);
  if constexpr ((kWhich & kGamma) != 0)
    std::fill (gamma, gamma + w, 0.f);
  for (const auto& d : offsets (step))
    if (y + d[1] >= 0 && y + d[1] < h)
    {
      if (test == ConvexityTest::NormalDivergence)
        edgeRowPass<kWhich, true> (planes, y, d[0], d[1], phi, gamma);
      else
        edgeRowPass<kWhich, false> (planes, y, d[0], d[1], phi, gamma);
    }
  const std::size_t base = static_cast<std::size_t> (y) * w;
  const float* z = planes.z.data () + base;
  const float* nx = planes.nx.data () + base;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const float inf = std::numeric_limits<float>::infinity ();
  for (int x = 0; x < w; ++x)
  {
    if constexpr ((kWhich & kPhi) != 0)
      phi[x] = (nx[x] == nx[x]) ? phi[x] : nan;  // no point or normal: no value
    if constexpr ((kWhich & kGamma) != 0)
      gamma[x] = (z[x] != z[x]) ? nan : (nx[x] != nx[x]) ? inf : gamma[x];
  }
}

/** Φ < the threshold at each pixel's depth: the configured one, lowered where the
  * normals' noise exceeds it (ConcavityEdgeEstimationConfig::noise_slope): with θ = s·σ_z(z)/z,
  * 1 − θ²/2 (the cosine to second order, so the loop vectorises).
  */
CUEFUSION_AVX2_CLONES void
concavityEdgeRow (const float* __restrict phi, const float* __restrict z, int w, float threshold, float noise_slope,
                  std::uint8_t* __restrict out)
{
  for (int x = 0; x < w; ++x)
  {
    const float theta = noise_slope * axialNoiseLowerBound (z[x]) / z[x];  // σ_z at normal incidence
    const float t = std::min (threshold, 1.f - 0.5f * theta * theta);
    out[x] = phi[x] < t ? 1 : 0;  // NaN compares false: no edge
  }
}

/** Γ > k·σ_d, +inf always, NaN never. */
void
discontinuityEdgeRow (const SurfacePlanes& planes, int y, const float* gamma, float k, std::uint8_t* out)
{
  const std::size_t base = static_cast<std::size_t> (y) * planes.width;
  for (int x = 0; x < planes.width; ++x)
  {
    const float g = gamma[x];
    bool edge = g == std::numeric_limits<float>::infinity ();
    if (!edge && g > 0.f)
    {
      const std::size_t i = base + x;
      edge = isDepthDiscontinuity (g, k, Eigen::Vector3f (planes.x[i], planes.y[i], planes.z[i]),
                                   Eigen::Vector3f (planes.nx[i], planes.ny[i], planes.nz[i]));
    }
    out[x] = edge ? 1 : 0;
  }
}
/** Central-difference normals of row y (see computeNormalPlanes); a function of its own
  * with everything passed by value, so that GCC vectorises the loop.
  */
CUEFUSION_AVX2_CLONES void
normalRow (const SurfacePlanes& planes, int y, int step, float max_depth_jump, float* __restrict NX, float* __restrict NY,
           float* __restrict NZ)
{
  const int w = planes.width;
  const std::size_t row = static_cast<std::size_t> (y) * w;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const float* __restrict X = planes.x.data () + row;
  const float* __restrict Y = planes.y.data () + row;
  const float* __restrict Z = planes.z.data () + row;
  const std::size_t up = row - static_cast<std::size_t> (step) * w, down = row + static_cast<std::size_t> (step) * w;
  const float* __restrict Xu = planes.x.data () + up;
  const float* __restrict Yu = planes.y.data () + up;
  const float* __restrict Zu = planes.z.data () + up;
  const float* __restrict Xd = planes.x.data () + down;
  const float* __restrict Yd = planes.y.data () + down;
  const float* __restrict Zd = planes.z.data () + down;
    for (int x = step; x + step < w; ++x)
    {
      // All loads first, then selects: no branches in the loop.
      const float px = X[x], py = Y[x], z = Z[x], limit = max_depth_jump * z;
      const float lx = X[x - step], ly = Y[x - step], lz = Z[x - step];
      const float rx = X[x + step], ry = Y[x + step], rz = Z[x + step];
      const float ux = Xu[x], uy = Yu[x], uz = Zu[x];
      const float dx = Xd[x], dy = Yd[x], dz = Zd[x];
      // Horizontal difference: central when both sides continue the surface, else one-sided.
      const bool l = std::abs (lz - z) < limit, r = std::abs (rz - z) < limit;  // NaN: false
      const float hx = (r ? rx : px) - (l ? lx : px);
      const float hy = (r ? ry : py) - (l ? ly : py);
      const float hz = (r ? rz : z) - (l ? lz : z);
      const bool u = std::abs (uz - z) < limit, d = std::abs (dz - z) < limit;
      const float vx = (d ? dx : px) - (u ? ux : px);
      const float vy = (d ? dy : py) - (u ? uy : py);
      const float vz = (d ? dz : z) - (u ? uz : z);
      const float cx = hy * vz - hz * vy, cy = hz * vx - hx * vz, cz = hx * vy - hy * vx;
      const float length = std::sqrt (cx * cx + cy * cy + cz * cz);
      // Turn towards the sensor (the origin): n·v < 0.
      const float sign = (cx * px + cy * py + cz * z) > 0.f ? -1.f : 1.f;
      // No usable side in one direction (or NaN depth): no normal. A zero cross product
      // gives 0/0 = NaN by itself.
      const float any_h = r ? 1.f : (l ? 1.f : 0.f), any_v = d ? 1.f : (u ? 1.f : 0.f);
      const float scale = (any_h * any_v > 0.f) ? sign / length : nan;
      NX[x] = cx * scale;
      NY[x] = cy * scale;
      NZ[x] = cz * scale;
    }
}

}  // namespace

void
computeNormalPlanes (SurfacePlanes& planes, int step, float max_depth_jump)
{
  const int w = planes.width, h = planes.height;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  parallelFor (h, [&] (int y) {
    const std::size_t row = static_cast<std::size_t> (y) * w;
    const auto clear = [&] (int first, int end) {
      for (std::vector<float>* plane : {&planes.nx, &planes.ny, &planes.nz})
        std::fill (plane->data () + row + first, plane->data () + row + end, nan);
    };
    // Border rows have no vertical neighbour on one side; normalRow writes columns
    // [step, w − step) of the others, so only their borders are cleared.
    if (y >= step && y + step < h && 2 * step < w)
    {
      clear (0, step);
      clear (w - step, w);
      normalRow (planes, y, step, max_depth_jump, planes.nx.data () + row, planes.ny.data () + row, planes.nz.data () + row);
    }
    else
      clear (0, w);
  });
}

void
computeConcavityMap (const SurfacePlanes& planes, int step, ConvexityTest test, cv::Mat& phi)
{
  phi.create (planes.height, planes.width, CV_32F);
  parallelFor (planes.height, [&] (int y) { edgeRow<kPhi> (planes, y, step, test, phi.ptr<float> (y), nullptr); });
}

void
computeDiscontinuityMap (const SurfacePlanes& planes, int step, cv::Mat& gamma)
{
  gamma.create (planes.height, planes.width, CV_32F);
  parallelFor (planes.height, [&] (int y) {
    edgeRow<kGamma> (planes, y, step, ConvexityTest::NormalDivergence, nullptr, gamma.ptr<float> (y));
  });
}

void
concavityEdges (const SurfacePlanes& planes, const cv::Mat& phi, const ConcavityEdgeEstimationConfig& config, cv::Mat& edges)
{
  edges.create (phi.size (), CV_8U);
  parallelFor (phi.rows, [&] (int y) {
    concavityEdgeRow (phi.ptr<float> (y), planes.z.data () + static_cast<std::size_t> (y) * planes.width, phi.cols,
                      config.threshold, config.noise_slope, edges.ptr<std::uint8_t> (y));
  });
}

void
discontinuityEdges (const SurfacePlanes& planes, const cv::Mat& gamma, float k, cv::Mat& edges)
{
  edges.create (gamma.size (), CV_8U);
  parallelFor (gamma.rows, [&] (int y) {
    discontinuityEdgeRow (planes, y, gamma.ptr<float> (y), k, edges.ptr<std::uint8_t> (y));
  });
}

void
computeEdgeMasks (const SurfacePlanes& planes, const ConcavityEdgeEstimationConfig& concavity, float noise_factor, cv::Mat& concave,
                  cv::Mat& depth_edges)
{
  concave.create (planes.height, planes.width, CV_8U);
  depth_edges.create (planes.height, planes.width, CV_8U);
  cuefusion::detail::serialUnderThreadSanitizer ();  // see common/parallel.h
  cv::parallel_for_ (cv::Range (0, planes.height), [&] (const cv::Range& rows) {
    std::vector<float> phi (static_cast<std::size_t> (planes.width)), gamma (phi.size ());
    for (int y = rows.start; y < rows.end; ++y)
    {
      edgeRow<kPhi | kGamma> (planes, y, concavity.neighbour_step, concavity.convexity_test, phi.data (), gamma.data ());
      concavityEdgeRow (phi.data (), planes.z.data () + static_cast<std::size_t> (y) * planes.width, planes.width,
                        concavity.threshold, concavity.noise_slope, concave.ptr<std::uint8_t> (y));
      discontinuityEdgeRow (planes, y, gamma.data (), noise_factor, depth_edges.ptr<std::uint8_t> (y));
    }
  });
}
}  // namespace segmentation
}  // namespace cuefusion
