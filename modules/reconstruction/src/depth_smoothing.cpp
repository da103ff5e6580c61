// Bilateral filtering of depth with a range kernel that follows the sensor noise.
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
// The noise model σ_z(z) = a + b (z − z0)² of Nguyen et al. at θ = 0 (kinectAxialNoise).
constexpr double kA = 0.0012, kB = 0.0019, kZ0 = 0.4;

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
}  // namespace

void
noiseAdaptiveBilateral (const cv::Mat& depth, int diameter, float range_sigma, float sigma_space, cv::Mat& filtered)
{
  static const NoiseUnits units;
  CV_Assert (depth.type () == CV_32F);
  // Invalid pixels sit 20 range σ below the smallest depth there can be: no weight for
  // anyone, and the value range OpenCV tabulates its range kernel over stays bounded.
  const float invalid = units.toUnits (0.f) - 20.f * range_sigma;
  cv::Mat u (depth.size (), CV_32F);
  parallelFor (depth.rows, [&] (int y) {
    const float* z = depth.ptr<float> (y);
    float* out = u.ptr<float> (y);
    for (int x = 0; x < depth.cols; ++x)
      out[x] = z[x] > 0.f ? units.toUnits (z[x]) : invalid;
  });
  cv::Mat smoothed;
  cv::bilateralFilter (u, smoothed, diameter, range_sigma, sigma_space);
  filtered.create (depth.size (), CV_32F);
  parallelFor (depth.rows, [&] (int y) {
    const float* z = depth.ptr<float> (y);
    const float* in = smoothed.ptr<float> (y);
    float* out = filtered.ptr<float> (y);
    for (int x = 0; x < depth.cols; ++x)
      out[x] = z[x] > 0.f ? units.toDepth (in[x]) : 0.f;
  });
}
}  // namespace reconstruction
}  // namespace cuefusion
