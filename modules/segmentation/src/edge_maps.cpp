// SPDX-License-Identifier: BSD-3-Clause
// The per-direction loops of the §4.2.1.1 edge operators over SurfacePlanes. Each pass
// compares every pixel with its neighbour at one offset (dx, dy); the inner loop over x
// reads contiguous floats and is vectorised by the compiler. NaN does the bookkeeping:
// a term involving a missing point or normal is NaN, and std::min/std::max(a, NaN) keep a.
// The two hot loops are also built for AVX2 (target_clones: the loader picks the clone
// for the CPU, whatever setVectorKernelsEnabled says; AVX2 without FMA, so both clones
// compute the same bits). Measured on icl-livingroom1: geometric segmentation 5.8 → 4.7
// ms a frame.
#include <cuefusion/common/avx2.h>
#include <cuefusion/reconstruction/vertex_maps.h>
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <algorithm>
#include <array>
#include <vector>

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

/** The normals the wide test compares, planar like SurfacePlanes': the planes' own, or
  * central differences over the test's wider span (ConcavityEdgeEstimationConfig::wideSpan). */
struct WideNormals
{
  const float* nx;
  const float* ny;
  const float* nz;
};

/** Φ_w,d of row y for one direction d = (dx, dy) (ConcavityEdgeEstimationConfig::wide_step):
  * the normals \a n at u − s·d and u + s·d, the same terms as edgeRowPass's; 1 where convex
  * or either side lacks a point or normal. */
template <bool kSymmetric>
CUEFUSION_AVX2_CLONES void
wideRowPass (const SurfacePlanes& p, const WideNormals& n, int y, int s, int dx, int dy, float max_jump, float wide_slope,
             float* __restrict phi)
{
  const int w = p.width;
  std::fill (phi, phi + w, 1.f);
  if (y - 3 * s * std::abs (dy) < 0 || y + 3 * s * std::abs (dy) >= p.height)
    return;
  const int x0 = 3 * s * std::abs (dx), x1 = w - 3 * s * std::abs (dx);
  const auto at = [&] (int k) { return static_cast<std::ptrdiff_t> (y + k * s * dy) * w + k * s * dx; };
  const std::ptrdiff_t a = at (-1), b = at (1), a2 = at (-3), b2 = at (3), u = at (0);
  const float* __restrict X = p.x.data () + a;
  const float* __restrict Y = p.y.data () + a;
  const float* __restrict Z = p.z.data () + a;
  const float* __restrict NX = n.nx + a;
  const float* __restrict NY = n.ny + a;
  const float* __restrict NZ = n.nz + a;
  const float* __restrict Xi = p.x.data () + b;
  const float* __restrict Yi = p.y.data () + b;
  const float* __restrict Zi = p.z.data () + b;
  const float* __restrict NXi = n.nx + b;
  const float* __restrict NYi = n.ny + b;
  const float* __restrict NZi = n.nz + b;
  const float* __restrict Zu = p.z.data () + u;
  for (int x = x0; x < x1; ++x)
  {
    const float ex = Xi[x] - X[x], ey = Yi[x] - Y[x], ez = Zi[x] - Z[x];
    const float agreement = NX[x] * NXi[x] + NY[x] * NYi[x] + NZ[x] * NZi[x];
    const float convexity =
      kSymmetric ? (NXi[x] - NX[x]) * ex + (NYi[x] - NY[x]) * ey + (NZi[x] - NZ[x]) * ez : -(ex * NX[x] + ey * NY[x] + ez * NZ[x]);
    const bool convex = kSymmetric ? convexity >= 0.f : convexity > 0.f;
    // Only a pair on one continuous surface: 2s pixels apart its depths differ by at most
    // max_jump of theirs (a surface up to 75° from the view); across an outline the two
    // normals are of a foreground and a background, no crease (Γ marks the outline).
    const bool continuous = std::abs (ez) <= max_jump * (Z[x] + Zi[x]);
    // Only between two surfaces that each stay flat 2s pixels further out (the normals at
    // u ∓ 3s·d agree with those at u ∓ s·d within the noise): walls, floors, furniture.
    // A small far object's faces are a few pixels; its creases are Φ's and the masks' to
    // find, and the wide pairs across it cut it into pieces the masks no longer unite.
    const float theta = normalNoiseAngle (Zu[x], wide_slope), t = 1.f - 0.5f * theta * theta;
    const float side_a = NX[x] * n.nx[a2 + x] + NY[x] * n.ny[a2 + x] + NZ[x] * n.nz[a2 + x];
    const float side_b = NXi[x] * n.nx[b2 + x] + NYi[x] * n.ny[b2 + x] + NZi[x] * n.nz[b2 + x];
    const bool flat_sides = side_a >= t && side_b >= t;  // NaN compares false
    phi[x] = convex || !continuous || !flat_sides || agreement != agreement ? 1.f : agreement;
  }
}

constexpr std::array<std::array<int, 2>, 4> kWideDirections{{{{1, 0}}, {{0, 1}}, {{1, 1}}, {{1, -1}}}};

/** The wide test's edges (ConcavityEdgeEstimationConfig::wide_step), CV_8U: Φ_w,d for each
  * direction d over the image, then u is an edge where, for some d, Φ_w,d(u) < cos θ_w(z)
  * and no smaller than at u ∓ d (non-maximum suppression across the crease: the pairs
  * straddle a crease for 2s pixels, and a band that wide ate small objects whole; the
  * crease's own line is one or two pixels, as Φ's), and only where θ(z) exceeds what a
  * right-angle crease turns the normals by per pixel. On a noisier sensor the span s and the
  * normals' differences widen with the noise (ConcavityEdgeEstimationConfig::wideSpan) and
  * θ_w shrinks by as much: a normal's angular noise is the depth noise over the span of its
  * differences. */
void
wideEdges (const SurfacePlanes& planes, const ConcavityEdgeEstimationConfig& config, cv::Mat& edges)
{
  const int w = planes.width, h = planes.height, s = config.wideSpan ();
  const float wide_slope = config.wide_noise_slope * static_cast<float> (config.wide_step) / static_cast<float> (s);
  edges = cv::Mat::zeros (h, w, CV_8U);
  // The pixels' angular size, from two neighbouring points of the middle row (an
  // organized cloud's rays): a surface 75° from the view changes depth by tan 75° of it
  // per pixel, z · tan 75° · 2s · (1/f) over the pair (half of it per point of the sum).
  float inverse_focal = 0.f;
  for (int y = h / 2, x = 0; x + 1 < w && inverse_focal <= 0.f; ++x)
  {
    const std::size_t i = static_cast<std::size_t> (y) * w + x;
    if (planes.z[i] > 0.f && planes.z[i + 1] > 0.f)
      inverse_focal = planes.x[i + 1] / planes.z[i + 1] - planes.x[i] / planes.z[i];
  }
  constexpr float kTan75 = 3.7320508f;
  const float max_jump = inverse_focal > 0.f ? 0.5f * kTan75 * 2.f * static_cast<float> (s) * inverse_focal
                                             : std::numeric_limits<float>::infinity ();
  // Where the wide test applies: θ(z) above what a right-angle crease turns Φ's normals
  // (the segmentation's ±wide_step px) by per pixel (elsewhere Φ sees such creases, or
  // there is no depth). Only the rows holding such a pixel, and their neighbours (the
  // suppression reads them), get Φ_w,d: a near view computes none.
  constexpr float kRightAngle = 1.57079633f;
  const float blend = kRightAngle / (2.f * static_cast<float> (config.wide_step));
  const auto applies = [&] (float z) { return normalNoiseAngle (z, config.noise_slope) > blend; };
  std::vector<char> needed (static_cast<std::size_t> (h), 0), computed (needed.size (), 0);
  parallelFor (h, [&] (int y) {
    const float* z = planes.z.data () + static_cast<std::size_t> (y) * w;
    needed[static_cast<std::size_t> (y)] = std::any_of (z, z + w, applies) ? 1 : 0;
  });
  for (int y = 0; y < h; ++y)
    for (int r = std::max (0, y - 1); r <= std::min (h - 1, y + 1); ++r)
      computed[static_cast<std::size_t> (y)] |= needed[static_cast<std::size_t> (r)];
  if (std::none_of (needed.begin (), needed.end (), [] (char n) { return n != 0; }))
    return;
  WideNormals normals{planes.nx.data (), planes.ny.data (), planes.nz.data ()};
  std::vector<float> wider_normals;
  if (s != config.wide_step)
  {
    const std::size_t n = planes.x.size ();
    wider_normals.resize (3 * n);
    reconstruction::NormalMapConfig wider = SurfacePreprocessingConfig::segmentationNormals ();
    wider.step = s;
    reconstruction::computeNormalMapPlanar (planes.x.data (), planes.y.data (), planes.z.data (), w, h, wider, wider_normals.data (),
                                            wider_normals.data () + n, wider_normals.data () + 2 * n);
    normals = {wider_normals.data (), wider_normals.data () + n, wider_normals.data () + 2 * n};
  }
  std::array<cv::Mat, 4> phi;
  for (std::size_t k = 0; k < kWideDirections.size (); ++k)
  {
    phi[k].create (h, w, CV_32F);
    parallelFor (h, [&] (int y) {
      if (!computed[static_cast<std::size_t> (y)])
        return;
      if (config.convexity_test == ConvexityTest::NormalDivergence)
        wideRowPass<true> (planes, normals, y, s, kWideDirections[k][0], kWideDirections[k][1], max_jump, wide_slope,
                           phi[k].ptr<float> (y));
      else
        wideRowPass<false> (planes, normals, y, s, kWideDirections[k][0], kWideDirections[k][1], max_jump, wide_slope,
                            phi[k].ptr<float> (y));
    });
  }
  parallelFor (h, [&] (int y) {
    if (!needed[static_cast<std::size_t> (y)])
      return;
    const float* z = planes.z.data () + static_cast<std::size_t> (y) * w;
    std::uint8_t* out = edges.ptr<std::uint8_t> (y);
    for (int x = 1; x + 1 < w; ++x)
    {
      if (!applies (z[x]))
        continue;
      const float theta = normalNoiseAngle (z[x], wide_slope), t = 1.f - 0.5f * theta * theta;
      for (std::size_t k = 0; k < kWideDirections.size () && !out[x]; ++k)
      {
        const int dx = kWideDirections[k][0], dy = kWideDirections[k][1];
        if (y - std::abs (dy) < 0 || y + std::abs (dy) >= h)
          continue;
        const float v = phi[k].at<float> (y, x);
        out[x] = v < t && v <= phi[k].at<float> (y - dy, x - dx) && v <= phi[k].at<float> (y + dy, x + dx) ? 1 : 0;
      }
    }
  });
}

/** Φ < the threshold at each pixel's depth: the configured one, lowered where the
  * normals' noise exceeds it (ConcavityEdgeEstimationConfig::noise_slope): with θ = s·σ_z(z)/z,
  * 1 − θ²/2 (the cosine to second order, so the loop vectorises); or the wide test's edge
  * (\a wide, null without it).
  */
CUEFUSION_AVX2_CLONES void
concavityEdgeRow (const float* __restrict phi, const std::uint8_t* __restrict wide, const float* __restrict z, int w,
                  float threshold, float noise_slope, std::uint8_t* __restrict out)
{
  for (int x = 0; x < w; ++x)
  {
    const float theta = normalNoiseAngle (z[x], noise_slope);
    const float t = std::min (threshold, 1.f - 0.5f * theta * theta);
    out[x] = phi[x] < t || (wide && wide[x]) ? 1 : 0;  // NaN compares false: no edge
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
}  // namespace

void
computeNormalPlanes (SurfacePlanes& planes, const reconstruction::NormalMapConfig& config)
{
  reconstruction::computeNormalMapPlanar (planes.x.data (), planes.y.data (), planes.z.data (), planes.width, planes.height,
                                          config, planes.nx.data (), planes.ny.data (), planes.nz.data ());
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
  cv::Mat wide;
  if (config.wide_step > 0)
    wideEdges (planes, config, wide);
  parallelFor (phi.rows, [&] (int y) {
    concavityEdgeRow (phi.ptr<float> (y), wide.empty () ? nullptr : wide.ptr<std::uint8_t> (y),
                      planes.z.data () + static_cast<std::size_t> (y) * planes.width, phi.cols, config.threshold, config.noise_slope,
                      edges.ptr<std::uint8_t> (y));
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
  cv::Mat wide;
  if (concavity.wide_step > 0)
    wideEdges (planes, concavity, wide);
  cuefusion::detail::serialUnderThreadSanitizer ();  // see common/parallel.h
  cv::parallel_for_ (cv::Range (0, planes.height), [&] (const cv::Range& rows) {
    std::vector<float> phi (static_cast<std::size_t> (planes.width)), gamma (phi.size ());
    for (int y = rows.start; y < rows.end; ++y)
    {
      edgeRow<kPhi | kGamma> (planes, y, concavity.neighbour_step, concavity.convexity_test, phi.data (), gamma.data ());
      concavityEdgeRow (phi.data (), wide.empty () ? nullptr : wide.ptr<std::uint8_t> (y),
                        planes.z.data () + static_cast<std::size_t> (y) * planes.width, planes.width, concavity.threshold,
                        concavity.noise_slope, concave.ptr<std::uint8_t> (y));
      discontinuityEdgeRow (planes, y, gamma.data (), noise_factor, depth_edges.ptr<std::uint8_t> (y));
    }
  });
}
}  // namespace segmentation
}  // namespace cuefusion
