// SPDX-License-Identifier: BSD-3-Clause
// Central-difference normals (§4.1.2): the one formula of the project, for tracking's
// pyramid (computeNormalMap on interleaved vertex maps) and the geometric segmentation
// (computeNormalMapPlanar on SurfacePlanes). The row loop reads contiguous floats and is
// vectorised by the compiler, built for AVX2 and baseline (CUEFUSION_AVX2_CLONES).
#include <cuefusion/common/avx2.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** Whether depths a, b, c, d, e of five evenly spaced pixels (b, d half-way) lie on one
  * plane: inverse depth linear across them to \a jump relative to c's — |c/a + c/e − 2| and
  * the half-way points' |2/b − 1/a − 1/c| · (a or e side's) within it, multiplied out so
  * that the loop needs no division (depths are positive; NaN: false). */
inline bool
onOnePlane (float a, float b, float c, float d, float e, float jump)
{
  return (std::abs (c * (a + e) - 2.f * a * e) < jump * a * e) & (std::abs (2.f * a * c - b * c - b * a) < jump * a * b) &
         (std::abs (2.f * e * c - d * c - d * e) < jump * e * d);
}

/** Normals of columns [step, w − step) of one row (see computeNormalMap): the pixels
  * ±step apart in the row, and the rows above and below at ∓\a offset floats from the
  * row's pointers. A function of its own with everything passed by value, so that GCC
  * vectorises the loop.
  */
CUEFUSION_AVX2_CLONES void
normalRow (const float* __restrict X, const float* __restrict Y, const float* __restrict Z, std::ptrdiff_t offset,
           int w, int step, float max_depth_jump, float* __restrict NX, float* __restrict NY, float* __restrict NZ)
{
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const float* __restrict Xu = X - offset;
  const float* __restrict Yu = Y - offset;
  const float* __restrict Zu = Z - offset;
  const float* __restrict Xd = X + offset;
  const float* __restrict Yd = Y + offset;
  const float* __restrict Zd = Z + offset;
  // Half-way points (step / 2 px; at step 1 the pixel itself), for the plane test below.
  const int half = step / 2;
  const std::ptrdiff_t half_offset = offset / step * half;
  const float* __restrict Zuh = Z - half_offset;
  const float* __restrict Zdh = Z + half_offset;
  for (int x = step; x + step < w; ++x)
  {
    // All loads first, then selects (the plane test below is the one branch, rarely taken).
    const float px = X[x], py = Y[x], z = Z[x], limit = max_depth_jump * z;
    const float lx = X[x - step], ly = Y[x - step], lz = Z[x - step];
    const float rx = X[x + step], ry = Y[x + step], rz = Z[x + step];
    const float ux = Xu[x], uy = Yu[x], uz = Zu[x];
    const float dx = Xd[x], dy = Yd[x], dz = Zd[x];
    // Horizontal difference: central when both sides continue the surface, else one-sided.
    // Both sides also continue it when the five points at 0, ±step/2 and ±step lie on one
    // plane — inverse depth linear across them, to max_depth_jump —, however much the
    // depth changes: a surface seen at a grazing angle far away (a table top at 3 m
    // changes depth by more than 2 % over ±4 px) had no normal, and every pixel without
    // one is a depth edge. The half-way points keep a narrow face between two others (the
    // side of a box standing before another) from passing for a plane.
    // (Tested only where a side fails the jump test: most pixels pass it.)
    bool l = std::abs (lz - z) < limit, r = std::abs (rz - z) < limit;  // NaN: false
    if (!(l & r) && onOnePlane (lz, Z[x - half], z, Z[x + half], rz, max_depth_jump))
      l = r = true;
    const float hx = (r ? rx : px) - (l ? lx : px);
    const float hy = (r ? ry : py) - (l ? ly : py);
    const float hz = (r ? rz : z) - (l ? lz : z);
    bool u = std::abs (uz - z) < limit, d = std::abs (dz - z) < limit;
    if (!(u & d) && onOnePlane (uz, Zuh[x], z, Zdh[x], dz, max_depth_jump))
      u = d = true;
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
NormalMapConfig::validate (const std::string& owner) const
{
  if (!(step >= 1 && step <= 16))
    throw ParameterError (owner + ".step", "must be 1..16 pixels");
  if (!(std::isfinite (max_depth_jump) && max_depth_jump > 0.f))
    throw ParameterError (owner + ".max_depth_jump", "must be positive");
}

void
computeNormalMapPlanar (const float* X, const float* Y, const float* Z, int width, int height,
                        const NormalMapConfig& config, float* NX, float* NY, float* NZ)
{
  const int step = config.step;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  parallelFor (height, [&] (int y) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t> (y) * width;
    const auto clear = [&] (int first, int end) {
      for (float* plane : {NX, NY, NZ})
        std::fill (plane + row + first, plane + row + end, nan);
    };
    // Border rows have no vertical neighbour on one side; the row loop writes columns
    // [step, width − step) of the others, so only their borders are cleared.
    if (y >= step && y + step < height && 2 * step < width)
    {
      clear (0, step);
      clear (width - step, width);
      normalRow (X + row, Y + row, Z + row, static_cast<std::ptrdiff_t> (step) * width, width, step, config.max_depth_jump,
                 NX + row, NY + row, NZ + row);
    }
    else
      clear (0, width);
  });
}

void
computeNormalMap (const cv::Mat& vertices, cv::Mat& normals, const NormalMapConfig& config)
{
  CV_Assert (vertices.type () == CV_32FC3);
  normals.create (vertices.size (), CV_32FC3);
  const int w = vertices.cols, h = vertices.rows, step = config.step;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  // The formula runs on planes (contiguous x, y, z, which the compiler vectorises): each
  // chunk of rows deinterleaves the rows it reads (its own and step more on either side)
  // once into a per-thread buffer that stays in the cache (whole-map planes cost more in
  // page faults than the formula itself; three rows per output row, a third more time),
  // then interleaves its normals into the map.
  constexpr int kRows = 16;
  parallelForChunks (h, kRows, [&] (int, int begin, int end) {
    const int first = std::max (0, begin - step), last = std::min (h, end + step);  // input rows [first, last)
    const std::size_t plane = static_cast<std::size_t> (last - first) * static_cast<std::size_t> (w);
    thread_local std::vector<float> buffer;
    buffer.resize (3 * plane + 3 * static_cast<std::size_t> (w));
    float* X = buffer.data ();
    float* Y = X + plane;
    float* Z = Y + plane;
    float* N[3] = {Z + plane, Z + plane + w, Z + plane + 2 * static_cast<std::size_t> (w)};
    for (int y = first; y < last; ++y)
    {
      const float* in = vertices.ptr<float> (y);
      const std::size_t row = static_cast<std::size_t> (y - first) * static_cast<std::size_t> (w);
      for (int x = 0; x < w; ++x)
      {
        X[row + x] = in[3 * x];
        Y[row + x] = in[3 * x + 1];
        Z[row + x] = in[3 * x + 2];
      }
    }
    for (int y = begin; y < end; ++y)
    {
      cv::Vec3f* out = normals.ptr<cv::Vec3f> (y);
      if (!(y >= step && y + step < h && 2 * step < w))
      {
        std::fill (out, out + w, cv::Vec3f (nan, nan, nan));
        continue;
      }
      const std::size_t row = static_cast<std::size_t> (y - first) * static_cast<std::size_t> (w);
      normalRow (X + row, Y + row, Z + row, static_cast<std::ptrdiff_t> (step) * w, w, step, config.max_depth_jump, N[0], N[1],
                 N[2]);
      for (int x = 0; x < w; ++x)
        out[x] = (x >= step && x + step < w) ? cv::Vec3f (N[0][x], N[1][x], N[2][x]) : cv::Vec3f (nan, nan, nan);
    }
  });
}
}  // namespace reconstruction
}  // namespace cuefusion
