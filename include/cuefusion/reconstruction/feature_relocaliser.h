// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Parameters of FeatureRelocaliser (ORB's and ORB-SLAM's defaults where they have one). */
struct FeatureRelocaliserConfig
{
  /// ORB keypoints per image. ORB-SLAM takes 1000 at 640×480, but matches them to a
  /// keyframe near the view; across a 30° jump to the last tracked frame (generated print
  /// textures, 640×480, tests FeatureRelocaliser.*) 1000 left 5–13 matches agreeing, 2000
  /// 21–24, 3000 26–38 at a third more time
  int features = 2000;
  float scale_factor = 1.2f;  ///< ORB's pyramid
  int levels = 8;
  /// Lowe's ratio test: a match is kept when its Hamming distance is below this times the
  /// second nearest's (ORB-SLAM's relocalisation: 0.75)
  double ratio = 0.95;
  int ransac_iterations = 300;
  /// A match agrees with a pose when the two points lie within this distance plus three
  /// times the sensor's noise at the point's depth (KinectNoiseModel), so a 3 m view
  /// agrees as readily as a 1 m one
  double inlier_distance = 0.02;
  /// a pose needs at least this many agreeing matches (wrong poses gathered at most 8 in
  /// the tests; ICP against the model verifies every pose found)
  std::size_t min_inliers = 15;
  std::size_t max_views = 500;    ///< keyframe views kept (88 kB each at 2000 features)
  /// SIFT keypoints per image for the wide-baseline match of a lost frame with the last
  /// tracked frame (relocaliseWide); 0 = none. ORB's descriptor changes with the view:
  /// right matches among the mutual nearest neighbours between generated printed views
  /// (640×480, Kinect noise) 30 / 36 / 45° apart: ORB (2000) 16 / 10 / 3, SIFT (2000)
  /// 87 / 60 / 25, SIFT (1000) – / 26 / 12. SIFT costs ~85 ms an image on one core
  /// against ORB's 7, so it describes only the last tracked frame (once a lost stretch)
  /// and some lost frames, never keyframes.
  int wide_features = 2000;
  std::uint32_t seed = 7;         ///< of RANSAC's samples

  void validate () const;
};

/** \brief ORB keypoints of one colour image, back-projected with its depth: the points
  * in the camera frame, row k of descriptors describes points[k]. */
struct FeatureView
{
  std::vector<Eigen::Vector3f> points;
  cv::Mat descriptors;  ///< ORB's CV_8U, 32 bytes a row; SIFT's CV_32F, 128 a row
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world of the image
};

/** \brief Wide-baseline relocalisation from colour and depth features (as ORB-SLAM's,
  * with 3D–3D matches instead of PnP since every keypoint has a depth): ORB keypoints of a
  * lost frame are matched (mutual nearest neighbours) to those of the last tracked frame
  * and of stored keyframes, and a rigid pose is found by RANSAC over three-match samples
  * (Umeyama's closed form), refitted to every agreeing match. Across a wide baseline only a
  * few per cent of the matches are right, so a sample is grown from one random match by
  * matches whose distance to it is the same in both views (a rigid motion keeps
  * distances): such triples are right far more often than random ones. The pose is a candidate only: the caller verifies
  * it by ICP against the model (DenseReconstruction::relocalise).
  *
  * Beyond about 30° ORB finds too few right matches; a lost frame is then matched to the
  * last tracked frame by SIFT, whose descriptor changes less with the view
  * (relocaliseWide; the same sampler and refit).
  *
  * Features are computed only when needed: a keyframe's when it is stored (a few a
  * minute), the last tracked frame's only when the next frame is lost (rememberTracked
  * keeps its image as grey and the caller's depth, a fraction of a millisecond), a lost
  * frame's once.
  *
  * RANSAC is written here, not PCL's SampleConsensusModelRegistration: that model has one
  * distance threshold for every point, and the sensor's noise at 3 m is ten times that at
  * 1 m.
  */
class FeatureRelocaliser
{
public:
  /** \brief A pose found from matches, and from which view. */
  struct Estimate
  {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world of the frame
    std::size_t inliers = 0;   ///< matches agreeing with it
    std::size_t matches = 0;   ///< matches that passed the ratio test
    std::string view;          ///< "last tracked frame" or "keyframe K"
  };

  explicit FeatureRelocaliser (const FeatureRelocaliserConfig& config = FeatureRelocaliserConfig ());

  const FeatureRelocaliserConfig& getConfig () const { return config_; }

  /** \brief The features of an image (CV_8UC3 BGR or CV_8UC1 grey) and its depth (CV_32F metres) seen by
    * \a camera from \a pose. A keypoint is kept where its depth is valid and its 3×3
    * neighbourhood does not straddle a depth edge (the point would lie on either side). */
  FeatureView
  describe (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera, const Eigen::Isometry3d& pose) const;

  /** \brief The rigid motion that takes \a frame's points onto \a view's, as the frame's
    * camera-to-world pose (view.pose × motion); none below min_inliers. */
  std::optional<Estimate>
  estimate (const FeatureView& frame, const FeatureView& view) const;

  /** \brief Keeps a tracked frame's image (as grey) and \a depth; its features are
    * computed only if a lost frame asks for them (relocalise). The depth is kept by
    * reference, not copied: the caller leaves it unchanged until the next call. */
  void
  rememberTracked (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera, const Eigen::Isometry3d& pose);

  /** \brief Stores the features of keyframe \a id (while fewer than max_views are kept). */
  void
  addKeyframe (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera, const Eigen::Isometry3d& pose,
               std::size_t id);

  /** \brief The pose of a lost frame from its features matched to the last tracked frame's
    * and to the stored keyframes among \a keyframes: the estimate with the most agreeing
    * matches, or none. */
  std::optional<Estimate>
  relocalise (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera, const std::vector<std::size_t>& keyframes);

  /** \brief The pose of a lost frame from SIFT features (wide_features) matched to the
    * last tracked frame's: a view further from it than ORB's descriptor reaches (a jump,
    * a blackout while the camera moved on). None when wide_features is 0, no frame was
    * tracked, or too few matches agree. Its view reads "last tracked frame, SIFT". */
  std::optional<Estimate>
  relocaliseWide (const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera);

  /** \brief Ids of the keyframes stored, in the order added. */
  std::vector<std::size_t> keyframeIds () const;

  /** \brief Forgets the keyframes and the last tracked frame. */
  void clear ();

private:
  const FeatureView&
  lastTrackedView ();

  /** describe() with \a detector's keypoints and descriptors (ORB's or SIFT's). */
  FeatureView
  describeWith (cv::Feature2D& detector, const cv::Mat& color, const cv::Mat& depth, const PinholeCamera& camera,
                const Eigen::Isometry3d& pose) const;

  FeatureRelocaliserConfig config_;
  cv::Ptr<cv::ORB> orb_;
  cv::Ptr<cv::SIFT> sift_;  ///< when wide_features > 0
  std::vector<std::pair<std::size_t, FeatureView>> keyframes_;
  struct Remembered
  {
    cv::Mat grey, depth;  ///< the image as grey; the caller's depth (rememberTracked)
    PinholeCamera camera;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
    std::optional<FeatureView> view;  ///< computed on first use
    std::optional<FeatureView> wide;  ///< its SIFT features, computed on first use
  } last_;
};
}  // namespace reconstruction
}  // namespace cuefusion
