// SPDX-License-Identifier: BSD-3-Clause
// Bilateral filtering of depth with a range kernel that follows the sensor noise.
#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/preprocessing.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
// The noise model σ_z(z) = a + b (z − z0)² of Nguyen et al. at θ = 0 (KinectNoiseModel).
constexpr double kA = KinectNoiseModel::base, kB = KinectNoiseModel::quadratic, kZ0 = KinectNoiseModel::offset;

/** Depth in "noise units": u(z) = ∫ dz / σ_z(z) = atan(√(b/a) (z − z0)) / √(ab). A
  * step of one σ_z is one unit at every depth, so a fixed range σ on u is a range σ
  * proportional to the noise on z. Tabulated: atan/tan per pixel would cost more than
  * the filter.
  */
class NoiseUnits
{
public:
  NoiseUnits ()
  {
    forward_.resize (kSteps + 1);
    for (int i = 0; i <= kSteps; ++i)
      forward_[i] = static_cast<float> (exact (kMaxDepth * i / kSteps));
    u_min_ = forward_.front ();
    u_max_ = forward_.back ();
    inverse_.resize (kSteps + 1);
    for (int i = 0; i <= kSteps; ++i)
    {
      const double u = u_min_ + (u_max_ - u_min_) * i / kSteps;
      inverse_[i] = static_cast<float> (kZ0 + std::tan (u * std::sqrt (kA * kB)) / std::sqrt (kB / kA));
    }
  }
  float
  toUnits (float z) const
  {
    return lookup (forward_, z / kMaxDepth * kSteps);
  }
  float
  toDepth (float u) const
  {
    return lookup (inverse_, (u - u_min_) / (u_max_ - u_min_) * kSteps);
  }
  float minUnits () const { return u_min_; }

private:
  static constexpr int kSteps = 1 << 15;
  static constexpr double kMaxDepth = 12.0;
  static double
  exact (double z)
  {
    return std::atan (std::sqrt (kB / kA) * (z - kZ0)) / std::sqrt (kA * kB);
  }
  static float
  lookup (const std::vector<float>& table, float position)
  {
    position = std::min (std::max (position, 0.f), static_cast<float> (kSteps) - 1e-3f);
    const int i = static_cast<int> (position);
    const float t = position - static_cast<float> (i);
    return table[i] + t * (table[i + 1] - table[i]);
  }
  std::vector<float> forward_, inverse_;
  float u_min_ = 0.f, u_max_ = 0.f;
};
/** \brief cv::bilateralFilter's window and weights: the offsets within \a diameter / 2 of
  * the centre (a disc), each with its spatial exponent −r²/(2σ_s²); the range exponent is
  * range_coefficient · Δ² with range_coefficient = −1/(2σ_r²). Weight = exp(sum of both).
  */
struct BilateralWindow
{
  std::vector<int> dx, dy;
  std::vector<float> space_exponent;
  float range_coefficient = 0.f;
  int radius = 0;

  BilateralWindow (int diameter, float range_sigma, float sigma_space)
  {
    radius = diameter / 2;
    range_coefficient = -0.5f / (range_sigma * range_sigma);
    const double space_coefficient = -0.5 / (static_cast<double> (sigma_space) * sigma_space);
    for (int i = -radius; i <= radius; ++i)
      for (int j = -radius; j <= radius; ++j)
      {
        if (std::sqrt (static_cast<double> (i * i + j * j)) > radius)
          continue;
        dy.push_back (i);
        dx.push_back (j);
        space_exponent.push_back (static_cast<float> ((i * i + j * j) * space_coefficient));
      }
  }
};

/** \brief One row of the bilateral filter on \a padded (the image with \a window.radius
  * reflected border pixels on every side), pixels [begin, end) of output row \a y.
  */
void
bilateralRowScalar (const cv::Mat& padded, const BilateralWindow& window, int y, int begin, int end, float* out)
{
  const int r = window.radius;
  const float* centre_row = padded.ptr<float> (y + r) + r;
  for (int x = begin; x < end; ++x)
  {
    const float centre = centre_row[x];
    float sum = 0.f, weight_sum = 0.f;
    for (std::size_t k = 0; k < window.dx.size (); ++k)
    {
      const float value = padded.ptr<float> (y + r + window.dy[k])[x + r + window.dx[k]];
      const float difference = value - centre;
      const float weight = std::exp (window.range_coefficient * difference * difference + window.space_exponent[k]);
      sum += weight * value;
      weight_sum += weight;
    }
    out[x] = sum / weight_sum;
  }
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
/** \brief e^x for x ≤ 0 in eight lanes (Cephes' expf: range reduction by ln 2 in two parts,
  * a degree-5 polynomial, the power of two put into the exponent bits), within a few ulp
  * of std::exp; below −87 it returns ~1e-38 instead of going subnormal.
  */
CUEFUSION_AVX2 inline __m256
expNonPositive8 (__m256 x)
{
  x = _mm256_max_ps (x, _mm256_set1_ps (-87.f));
  const __m256 n = _mm256_floor_ps (_mm256_fmadd_ps (x, _mm256_set1_ps (1.44269504088896341f), _mm256_set1_ps (0.5f)));
  x = _mm256_fnmadd_ps (n, _mm256_set1_ps (0.693359375f), x);
  x = _mm256_fnmadd_ps (n, _mm256_set1_ps (-2.12194440e-4f), x);
  __m256 y = _mm256_set1_ps (1.9875691500e-4f);
  y = _mm256_fmadd_ps (y, x, _mm256_set1_ps (1.3981999507e-3f));
  y = _mm256_fmadd_ps (y, x, _mm256_set1_ps (8.3334519073e-3f));
  y = _mm256_fmadd_ps (y, x, _mm256_set1_ps (4.1665795894e-2f));
  y = _mm256_fmadd_ps (y, x, _mm256_set1_ps (1.6666665459e-1f));
  y = _mm256_fmadd_ps (y, x, _mm256_set1_ps (5.0000001201e-1f));
  y = _mm256_fmadd_ps (y, _mm256_mul_ps (x, x), _mm256_add_ps (x, _mm256_set1_ps (1.f)));
  const __m256i power = _mm256_slli_epi32 (_mm256_add_epi32 (_mm256_cvttps_epi32 (n), _mm256_set1_epi32 (127)), 23);
  return _mm256_mul_ps (y, _mm256_castsi256_ps (power));
}

/** \brief bilateralRowScalar eight pixels at a time; returns the first pixel not done.
  * The same sums in the same order per pixel, with expNonPositive8 for std::exp.
  * cv::bilateralFilter on float images tabulates the range kernel and reads the table
  * per neighbour (gathers in its vector code), which cost 2.5–3 ms a 640×480 frame here;
  * this is ~4× faster.
  */
CUEFUSION_AVX2 int
bilateralRowAvx2 (const cv::Mat& padded, const BilateralWindow& window, int y, int begin, int end, float* out)
{
  const int r = window.radius;
  const float* centre_row = padded.ptr<float> (y + r) + r;
  const __m256 range_coefficient = _mm256_set1_ps (window.range_coefficient);
  const std::size_t taps = window.dx.size ();
  int x = begin;
  for (; x + 8 <= end; x += 8)
  {
    const __m256 centre = _mm256_loadu_ps (centre_row + x);
    __m256 sum = _mm256_setzero_ps (), weight_sum = _mm256_setzero_ps ();
    for (std::size_t k = 0; k < taps; ++k)
    {
      const __m256 value = _mm256_loadu_ps (padded.ptr<float> (y + r + window.dy[k]) + x + r + window.dx[k]);
      const __m256 difference = _mm256_sub_ps (value, centre);
      const __m256 weight = expNonPositive8 (_mm256_add_ps (
          _mm256_mul_ps (_mm256_mul_ps (range_coefficient, difference), difference), _mm256_set1_ps (window.space_exponent[k])));
      sum = _mm256_add_ps (sum, _mm256_mul_ps (weight, value));
      weight_sum = _mm256_add_ps (weight_sum, weight);
    }
    _mm256_storeu_ps (out + x, _mm256_div_ps (sum, weight_sum));
  }
  return x;
}
#endif
}  // namespace

void
noiseAdaptiveBilateral (const cv::Mat& depth, int diameter, float range_sigma, float sigma_space, cv::Mat& filtered)
{
  static const NoiseUnits units;
  CV_Assert (depth.type () == CV_32F);
  // Invalid pixels sit 20 range σ below the smallest depth there can be: no weight for
  // anyone (e^-200).
  const float invalid = units.toUnits (0.f) - 20.f * range_sigma;
  // The bilateral filter of cv::bilateralFilter (same disc of neighbours, weights and
  // reflected border), written out: see bilateralRowAvx2 for why. Its input, the depth in
  // noise units with the border reflected (OpenCV's BORDER_REFLECT_101), is written
  // straight into a buffer kept between calls: a fresh image and cv::copyMakeBorder cost
  // 0.7 ms a frame, mostly page faults.
  const BilateralWindow window (diameter, range_sigma, sigma_space);
  const int r = window.radius;
  const auto reflect = [] (int i, int n) {
    while (n > 1 && (i < 0 || i >= n))
      i = i < 0 ? -i : 2 * n - 2 - i;
    return n > 1 ? i : 0;
  };
  thread_local cv::Mat buffer;
  cv::Mat& padded = buffer;  // the calling thread's, in the workers too (a thread_local named
                             // inside the lambdas would be each worker's own)
  padded.create (depth.rows + 2 * r, depth.cols + 2 * r, CV_32F);
  parallelForChunks (padded.rows, 8, [&] (int, int begin, int end) {
    for (int py = begin; py < end; ++py)
    {
      const float* z = depth.ptr<float> (reflect (py - r, depth.rows));
      float* out = padded.ptr<float> (py);
      for (int px = 0; px < padded.cols; ++px)
      {
        const int x = px >= r && px < r + depth.cols ? px - r : reflect (px - r, depth.cols);
        out[px] = z[x] > 0.f ? units.toUnits (z[x]) : invalid;
      }
    }
  });
  filtered.create (depth.size (), CV_32F);
  [[maybe_unused]] const bool use_avx2 = vectorKernelsEnabled ();
  parallelForChunks (depth.rows, 8, [&] (int, int begin, int end) {
    std::vector<float> smoothed (static_cast<std::size_t> (depth.cols));
    for (int y = begin; y < end; ++y)
    {
      int x = 0;
#ifdef CUEFUSION_HAVE_AVX2_KERNELS
      if (use_avx2)
        x = bilateralRowAvx2 (padded, window, y, 0, depth.cols, smoothed.data ());
#endif
      bilateralRowScalar (padded, window, y, x, depth.cols, smoothed.data ());
      const float* z = depth.ptr<float> (y);
      float* out = filtered.ptr<float> (y);
      for (int i = 0; i < depth.cols; ++i)
        out[i] = z[i] > 0.f ? units.toDepth (smoothed[static_cast<std::size_t> (i)]) : 0.f;
    }
  });
}
}  // namespace reconstruction
}  // namespace cuefusion
