// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/feature_relocaliser.h>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** Closed-form rigid motion taking \a from onto \a to (Umeyama 1991, no scale). */
Eigen::Isometry3d
rigidMotion (const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to)
{
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity ();
  motion.matrix () = Eigen::umeyama (from, to, false);
  return motion;
}

/** Mutual nearest neighbours (frame row, view column) of a matrix of every distance
  * between two descriptor sets (one matrix serves both directions: half the work of two
  * matchers), each passing the ratio test against the row's second nearest. */
template <typename Distance>
std::vector<std::pair<int, int>>
mutualMatches (const cv::Mat& distances, double ratio)
{
  std::vector<int> column_best (static_cast<std::size_t> (distances.cols), -1);
  std::vector<Distance> column_distance (static_cast<std::size_t> (distances.cols), std::numeric_limits<Distance>::max ());
  std::vector<int> row_best (static_cast<std::size_t> (distances.rows), -1);
  for (int r = 0; r < distances.rows; ++r)
  {
    const Distance* row = distances.ptr<Distance> (r);
    Distance first = std::numeric_limits<Distance>::max (), second = first;
    for (int c = 0; c < distances.cols; ++c)
    {
      if (row[c] < first)
      {
        second = first;
        first = row[c];
        row_best[static_cast<std::size_t> (r)] = c;
      }
      else if (row[c] < second)
        second = row[c];
      if (row[c] < column_distance[static_cast<std::size_t> (c)])
      {
        column_distance[static_cast<std::size_t> (c)] = row[c];
        column_best[static_cast<std::size_t> (c)] = r;
      }
    }
    if (!(static_cast<double> (first) < ratio * static_cast<double> (second)))
      row_best[static_cast<std::size_t> (r)] = -1;
  }
  std::vector<std::pair<int, int>> matches;
  for (int r = 0; r < distances.rows; ++r)
  {
    const int c = row_best[static_cast<std::size_t> (r)];
    if (c >= 0 && column_best[static_cast<std::size_t> (c)] == r)
      matches.emplace_back (r, c);
  }
  return matches;
}

/** Where a match agrees with a motion: config's distance plus three σ_z at its depth. */
double
agreementDistance (const FeatureRelocaliserConfig& config, float depth)
{
  return config.inlier_distance + 3.0 * KinectNoiseModel::atNormalIncidence (depth);
}
}  // namespace

void
FeatureRelocaliserConfig::validate () const
{
  if (features < 10 || features > 100000)
    throw ParameterError ("FeatureRelocaliserConfig::features", "must lie in [10, 100000]");
  if (!(scale_factor > 1.0f && scale_factor <= 2.0f))
    throw ParameterError ("FeatureRelocaliserConfig::scale_factor", "must lie in (1, 2]");
  if (levels < 1 || levels > 16)
    throw ParameterError ("FeatureRelocaliserConfig::levels", "must lie in [1, 16]");
  if (!(ratio > 0.0 && ratio <= 1.0))
    throw ParameterError ("FeatureRelocaliserConfig::ratio", "must lie in (0, 1]");
  if (ransac_iterations < 1 || ransac_iterations > 100000)
    throw ParameterError ("FeatureRelocaliserConfig::ransac_iterations", "must lie in [1, 100000]");
  if (!(inlier_distance > 0.0 && inlier_distance <= 1.0))
    throw ParameterError ("FeatureRelocaliserConfig::inlier_distance", "must lie in (0, 1] metres");
  if (min_inliers < 3)
    throw ParameterError ("FeatureRelocaliserConfig::min_inliers", "must be at least 3 (a rigid motion)");
  if (wide_features < 0 || wide_features > 100000)
    throw ParameterError ("FeatureRelocaliserConfig::wide_features", "must lie in [0, 100000] (0: none)");
}

FeatureRelocaliser::FeatureRelocaliser (const FeatureRelocaliserConfig& config) : config_ (config)
{
  config_.validate ();
  orb_ = cv::ORB::create (config_.features, config_.scale_factor, config_.levels);
  if (config_.wide_features > 0)
    sift_ = cv::SIFT::create (config_.wide_features);
}

FeatureView
FeatureRelocaliser::describe (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera,
                              const Eigen::Isometry3d& pose) const
{
  return describeWith (*orb_, color, depth, camera, pose);
}

FeatureView
FeatureRelocaliser::describeWith (cv::Feature2D& detector, const cv::Mat& color, const cv::Mat& depth,
                                  const PinholeCamera& camera, const Eigen::Isometry3d& pose) const
{
  FeatureView view;
  view.pose = pose;
  if (color.empty () || depth.empty () || color.size () != depth.size () || (color.type () != CV_8UC3 && color.type () != CV_8UC1) ||
      depth.type () != CV_32F)
    return view;
  cv::Mat grey, descriptors;
  if (color.type () == CV_8UC3)
    cv::cvtColor (color, grey, cv::COLOR_BGR2GRAY);
  else
    grey = color;
  std::vector<cv::KeyPoint> keypoints;
  detector.detectAndCompute (grey, cv::noArray (), keypoints, descriptors);
  std::vector<int> kept;
  for (std::size_t k = 0; k < keypoints.size (); ++k)
  {
    const int u = static_cast<int> (std::lround (keypoints[k].pt.x)), v = static_cast<int> (std::lround (keypoints[k].pt.y));
    if (u < 1 || v < 1 || u >= depth.cols - 1 || v >= depth.rows - 1)
      continue;
    float lowest = depth.at<float> (v, u), highest = lowest;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du)
      {
        const float z = depth.at<float> (v + dv, u + du);
        if (!(z > 0.f))  // NaN too
          lowest = 0.f;
        highest = std::max (highest, z);
        lowest = std::min (lowest, z);
      }
    const float z = depth.at<float> (v, u);
    if (!(lowest > 0.f) || highest - lowest > 3.f * KinectNoiseModel::atNormalIncidence (z) + 0.01f * z)
      continue;
    view.points.push_back (camera.backProject (keypoints[k].pt.x, keypoints[k].pt.y, z));
    kept.push_back (static_cast<int> (k));
  }
  view.descriptors.create (static_cast<int> (kept.size ()), descriptors.cols, descriptors.type ());
  for (std::size_t k = 0; k < kept.size (); ++k)
    descriptors.row (kept[k]).copyTo (view.descriptors.row (static_cast<int> (k)));
  return view;
}

std::optional<FeatureRelocaliser::Estimate>
FeatureRelocaliser::estimate (const FeatureView& frame, const FeatureView& view) const
{
  if (frame.points.size () < config_.min_inliers || view.points.size () < config_.min_inliers)
    return std::nullopt;
  // Mutual nearest neighbours that pass a loose ratio test: across a wide baseline the
  // right match is often not much nearer than the second (the descriptor changes with
  // the view), so the sampler below, not the test, sorts them out.
  if (frame.descriptors.type () != view.descriptors.type ())
    return std::nullopt;
  const bool binary = frame.descriptors.type () == CV_8U;  // ORB's; SIFT's are CV_32F
  cv::Mat distances;
  cv::batchDistance (frame.descriptors, view.descriptors, distances, binary ? CV_32S : CV_32F, cv::noArray (),
                     binary ? cv::NORM_HAMMING : cv::NORM_L2);
  const std::vector<std::pair<int, int>> matches =
      binary ? mutualMatches<int> (distances, config_.ratio) : mutualMatches<float> (distances, config_.ratio);
  if (matches.size () < config_.min_inliers)
    return std::nullopt;

  Eigen::Matrix3Xd from (3, static_cast<Eigen::Index> (matches.size ())), to (3, from.cols ());
  std::vector<double> tolerance (matches.size ());
  for (std::size_t m = 0; m < matches.size (); ++m)
  {
    const Eigen::Vector3f& p = frame.points[static_cast<std::size_t> (matches[m].first)];
    const Eigen::Vector3f& q = view.points[static_cast<std::size_t> (matches[m].second)];
    from.col (static_cast<Eigen::Index> (m)) = p.cast<double> ();
    to.col (static_cast<Eigen::Index> (m)) = q.cast<double> ();
    tolerance[m] = agreementDistance (config_, std::max (p.z (), q.z ()));
  }
  const auto agreeing = [&] (const Eigen::Isometry3d& motion) {
    std::vector<Eigen::Index> inliers;
    for (Eigen::Index m = 0; m < from.cols (); ++m)
      if ((motion * from.col (m) - to.col (m)).norm () < tolerance[static_cast<std::size_t> (m)])
        inliers.push_back (m);
    return inliers;
  };

  // Samples of three matches whose distances to each other agree in both views (a rigid
  // motion keeps them): among a few per cent of right matches, random triples are almost
  // never right, triples grown this way often are.
  const auto consistent = [&] (Eigen::Index i, Eigen::Index j) {
    const double in_frame = (from.col (i) - from.col (j)).norm (), in_view = (to.col (i) - to.col (j)).norm ();
    return in_frame > 0.05 && std::abs (in_frame - in_view) < tolerance[static_cast<std::size_t> (i)] + tolerance[static_cast<std::size_t> (j)];
  };
  std::mt19937 random (config_.seed);
  std::uniform_int_distribution<Eigen::Index> pick (0, from.cols () - 1);
  std::vector<Eigen::Index> best, partners, thirds;
  for (int iteration = 0; iteration < config_.ransac_iterations; ++iteration)
  {
    const Eigen::Index a = pick (random);
    partners.clear ();
    for (Eigen::Index m = 0; m < from.cols (); ++m)
      if (m != a && consistent (a, m))
        partners.push_back (m);
    if (partners.size () < 2)
      continue;
    const Eigen::Index b = partners[std::uniform_int_distribution<std::size_t> (0, partners.size () - 1) (random)];
    thirds.clear ();
    for (const Eigen::Index m : partners)
      if (m != b && consistent (b, m))
        thirds.push_back (m);
    if (thirds.empty ())
      continue;
    const Eigen::Index c = thirds[std::uniform_int_distribution<std::size_t> (0, thirds.size () - 1) (random)];
    // Three points spread apart (a sliver fixes no rotation).
    if ((from.col (b) - from.col (a)).cross (from.col (c) - from.col (a)).norm () < 1e-3)  // twice 5 cm²
      continue;
    Eigen::Matrix3d sample_from, sample_to;
    sample_from << from.col (a), from.col (b), from.col (c);
    sample_to << to.col (a), to.col (b), to.col (c);
    std::vector<Eigen::Index> inliers = agreeing (rigidMotion (sample_from, sample_to));
    if (inliers.size () > best.size ())
      best = std::move (inliers);
  }
  if (best.size () < config_.min_inliers)
    return std::nullopt;
  // Refit to every agreeing match, twice (the refit may gather a few more).
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity ();
  for (int refit = 0; refit < 2 && best.size () >= config_.min_inliers; ++refit)
  {
    Eigen::Matrix3Xd inlier_from (3, static_cast<Eigen::Index> (best.size ())), inlier_to (3, inlier_from.cols ());
    for (std::size_t k = 0; k < best.size (); ++k)
    {
      inlier_from.col (static_cast<Eigen::Index> (k)) = from.col (best[k]);
      inlier_to.col (static_cast<Eigen::Index> (k)) = to.col (best[k]);
    }
    motion = rigidMotion (inlier_from, inlier_to);
    best = agreeing (motion);
  }
  if (best.size () < config_.min_inliers)
    return std::nullopt;
  Estimate result;
  result.pose = view.pose * motion;
  result.inliers = best.size ();
  result.matches = matches.size ();
  return result;
}

void
FeatureRelocaliser::rememberTracked (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera,
                                     const Eigen::Isometry3d& pose)
{
  if (color.type () == CV_8UC3)
    cv::cvtColor (color, last_.grey, cv::COLOR_BGR2GRAY);  // a third of a copy of the colour
  else
    color.copyTo (last_.grey);
  last_.depth = depth;
  last_.camera = camera;
  last_.pose = pose;
  last_.view.reset ();
  last_.wide.reset ();
}

const FeatureView&
FeatureRelocaliser::lastTrackedView ()
{
  if (!last_.view)
    last_.view = describe (last_.grey, last_.depth, last_.camera, last_.pose);
  return *last_.view;
}

void
FeatureRelocaliser::addKeyframe (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera,
                                 const Eigen::Isometry3d& pose, std::size_t id)
{
  if (keyframes_.size () >= config_.max_views || color.empty ())
    return;
  keyframes_.emplace_back (id, describe (color, depth, camera, pose));
}

std::optional<FeatureRelocaliser::Estimate>
FeatureRelocaliser::relocalise (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera,
                                const std::vector<std::size_t>& keyframes)
{
  if (color.empty ())
    return std::nullopt;
  const FeatureView frame = describe (color, depth, camera, Eigen::Isometry3d::Identity ());
  if (frame.points.size () < config_.min_inliers)
    return std::nullopt;
  std::optional<Estimate> best;
  const auto consider = [&] (const FeatureView& view, const std::string& name) {
    std::optional<Estimate> found = estimate (frame, view);
    if (found && (!best || found->inliers > best->inliers))
    {
      best = std::move (found);
      best->view = name;
    }
  };
  if (!last_.grey.empty ())
    consider (lastTrackedView (), "last tracked frame");
  for (const std::size_t id : keyframes)
    for (const auto& [stored, view] : keyframes_)
      if (stored == id)
        consider (view, "keyframe " + std::to_string (id));
  return best;
}

std::optional<FeatureRelocaliser::Estimate>
FeatureRelocaliser::relocaliseWide (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera)
{
  if (!sift_ || color.empty () || last_.grey.empty ())
    return std::nullopt;
  const FeatureView frame = describeWith (*sift_, color, depth, camera, Eigen::Isometry3d::Identity ());
  if (!last_.wide)
    last_.wide = describeWith (*sift_, last_.grey, last_.depth, last_.camera, last_.pose);
  std::optional<Estimate> found = estimate (frame, *last_.wide);
  if (found)
    found->view = "last tracked frame, SIFT";
  return found;
}

std::vector<std::size_t>
FeatureRelocaliser::keyframeIds () const
{
  std::vector<std::size_t> ids;
  for (const auto& stored : keyframes_)
    ids.push_back (stored.first);
  return ids;
}

void
FeatureRelocaliser::clear ()
{
  keyframes_.clear ();
  last_ = Remembered ();
}
}  // namespace reconstruction
}  // namespace cuefusion
