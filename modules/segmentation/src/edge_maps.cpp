// The per-direction loops of the §4.2.1.1 edge operators over SurfacePlanes. Each pass
// compares every pixel with its neighbour at one offset (dx, dy); the inner loop over x
// reads contiguous floats and is vectorised by the compiler. NaN does the bookkeeping:
// a term involving a missing point or normal is NaN, and std::min/std::max(a, NaN) keep a.
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <algorithm>
#include <array>

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

template <bool kSymmetric>
void
concavityRowPass (const SurfacePlanes& p, int y, int dx, int dy, float* __restrict phi)
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
  for (int x = x0; x < x1; ++x)
  {
    const float ex = Xi[x] - X[x], ey = Yi[x] - Y[x], ez = Zi[x] - Z[x];
    const float agreement = NX[x] * NXi[x] + NY[x] * NYi[x] + NZ[x] * NZi[x];
    // Same tests as concavityTerm / concavityTermSymmetric (edge_operators.h), spelled out
    // on plain floats so that the loop vectorises.
    const float convexity = kSymmetric ? (NXi[x] - NX[x]) * ex + (NYi[x] - NY[x]) * ey + (NZi[x] - NZ[x]) * ez
                                       : -(ex * NX[x] + ey * NY[x] + ez * NZ[x]);
    const bool convex = kSymmetric ? convexity >= 0.f : convexity > 0.f;
    const float term = convex ? 1.f : agreement;   // NaN when either side lacks a point or normal
    phi[x] = std::min (phi[x], term);
  }
}

void
discontinuityRowPass (const SurfacePlanes& p, int y, int dx, int dy, float* __restrict gamma)
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
  const float inf = std::numeric_limits<float>::infinity ();
  for (int x = x0; x < x1; ++x)
  {
    const float distance = std::abs ((Xi[x] - X[x]) * NX[x] + (Yi[x] - Y[x]) * NY[x] + (Zi[x] - Z[x]) * NZ[x]);
    const float term = (Zi[x] != Zi[x]) ? inf : distance;  // a missing neighbour is an edge
    gamma[x] = std::max (gamma[x], term);
  }
}
}  // namespace

void
computeNormalPlanes (SurfacePlanes& planes, int step, float max_depth_jump)
{
  const int w = planes.width, h = planes.height;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
  {
    const std::size_t row = static_cast<std::size_t> (y) * w;
    float* __restrict NX = planes.nx.data () + row;
    float* __restrict NY = planes.ny.data () + row;
    float* __restrict NZ = planes.nz.data () + row;
    std::fill (NX, NX + w, nan);
    std::fill (NY, NY + w, nan);
    std::fill (NZ, NZ + w, nan);
    if (y < step || y + step >= h)
      continue;  // no vertical neighbours on one side: left without normal (border rows)
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
      // All loads first, then selects: lets the compiler vectorise without branches.
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
      const bool ok = (l | r) & (u | d) & (length > 0.f);  // false for NaN depth too
      const float scale = ok ? sign / length : nan;
      NX[x] = cx * scale;
      NY[x] = cy * scale;
      NZ[x] = cz * scale;
    }
  }
}

void
computeConcavityMap (const SurfacePlanes& planes, int step, ConvexityTest test, cv::Mat& phi)
{
  const int w = planes.width, h = planes.height;
  phi.create (h, w, CV_32F);
  const auto directions = offsets (step);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
  {
    float* row = phi.ptr<float> (y);
    std::fill (row, row + w, 1.f);
    for (const auto& d : directions)
      if (y + d[1] >= 0 && y + d[1] < h)
      {
        if (test == ConvexityTest::NormalDivergence)
          concavityRowPass<true> (planes, y, d[0], d[1], row);
        else
          concavityRowPass<false> (planes, y, d[0], d[1], row);
      }
    const float* nx = planes.nx.data () + static_cast<std::size_t> (y) * w;
    for (int x = 0; x < w; ++x)
      row[x] = (nx[x] == nx[x]) ? row[x] : nan;  // no point or normal: no value
  }
}

void
computeDiscontinuityMap (const SurfacePlanes& planes, int step, cv::Mat& gamma)
{
  const int w = planes.width, h = planes.height;
  gamma.create (h, w, CV_32F);
  const auto directions = offsets (step);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const float inf = std::numeric_limits<float>::infinity ();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
  {
    float* row = gamma.ptr<float> (y);
    std::fill (row, row + w, 0.f);
    for (const auto& d : directions)
      if (y + d[1] >= 0 && y + d[1] < h)
        discontinuityRowPass (planes, y, d[0], d[1], row);
    const float* z = planes.z.data () + static_cast<std::size_t> (y) * w;
    const float* nx = planes.nx.data () + static_cast<std::size_t> (y) * w;
    for (int x = 0; x < w; ++x)
      row[x] = (z[x] != z[x]) ? nan : (nx[x] != nx[x]) ? inf : row[x];
  }
}

void
concavityEdges (const cv::Mat& phi, float threshold, cv::Mat& edges)
{
  edges.create (phi.size (), CV_8U);
  for (int y = 0; y < phi.rows; ++y)
  {
    const float* in = phi.ptr<float> (y);
    std::uint8_t* out = edges.ptr<std::uint8_t> (y);
    for (int x = 0; x < phi.cols; ++x)
      out[x] = in[x] < threshold ? 1 : 0;  // NaN compares false: no edge
  }
}

void
discontinuityEdges (const SurfacePlanes& planes, const cv::Mat& gamma, float k, cv::Mat& edges)
{
  edges.create (gamma.size (), CV_8U);
  const float inf = std::numeric_limits<float>::infinity ();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < gamma.rows; ++y)
  {
    const float* in = gamma.ptr<float> (y);
    std::uint8_t* out = edges.ptr<std::uint8_t> (y);
    const std::size_t base = static_cast<std::size_t> (y) * gamma.cols;
    for (int x = 0; x < gamma.cols; ++x)
    {
      const float g = in[x];
      bool edge = g == inf;
      if (!edge && g > 0.f)
      {
        const std::size_t i = base + x;
        const Eigen::Vector3f v (planes.x[i], planes.y[i], planes.z[i]);
        const Eigen::Vector3f n (planes.nx[i], planes.ny[i], planes.nz[i]);
        edge = isDepthDiscontinuity (g, k, v, n);
      }
      out[x] = edge ? 1 : 0;
    }
  }
}
}  // namespace segmentation
}  // namespace cuefusion
