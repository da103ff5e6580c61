#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief Parameters of InstanceGuidedRegionMerge (§4.2.1.3). */
struct InstanceGuidedMergeConfig
{
  float min_overlap = 0.70f;  ///< α(l_s, l_g) must exceed this for l_g to join instance l_s
  void validate () const;
};

/** \brief What one segment of L_t is: the instance it was merged under (class and score
  * from the instance cue), or a purely geometric segment (instance −1, class −1).
  */
struct SegmentInstance
{
  int instance = -1;         ///< index into the instances given to merge(), −1 = none
  int class_id = -1;
  std::string class_name;
  float score = 0.f;
  int geometric_segments = 0;  ///< how many segments of L^G it unites
};

/** \brief Fuses the geometric label map L^G with instance masks into L_t (§4.2.1.3).
  *
  * For each geometric segment l_g, α(l_s, l_g) = |l_g ∩ l_s| / |l_g| for every instance
  * l_s, and the instance with the largest α is kept. All segments whose best instance is
  * the same l_s with α > min_overlap become one segment of L_t carrying that instance's
  * class and score; the others stay as they are (geometry still separates what the network
  * does not know, §2.1.3). Where masks overlap, the higher score owns the pixel. Pixels
  * that are 0 in L^G stay 0: the masks group segments, they do not draw new boundaries.
  * Output labels are 1..M in raster order of each segment's first pixel, so the result
  * depends only on the inputs.
  *
  * A mask that covers two objects (thesis Fig. 5.19) unites them when each object's
  * segments lie more than min_overlap inside it: the merge is wrong but kept — later
  * frames and the map (issue 6) are where it can be undone. A mask that leaks onto the
  * table does not take the table: the leak is a small part of the table's segment.
  */
class InstanceGuidedRegionMerge
{
public:
  explicit InstanceGuidedRegionMerge (const InstanceGuidedMergeConfig& config = InstanceGuidedMergeConfig ());

  void setConfig (const InstanceGuidedMergeConfig& config);
  const InstanceGuidedMergeConfig& getConfig () const { return config_; }

  /** \param[in] geometric L^G, CV_32S, 0 = no segment
    * \param[in] instances masks of the frame's size (CV_8U); may be empty (then L_t = L^G
    *            relabelled in raster order, which leaves OpenCV-numbered L^G unchanged)
    * \param[out] fused L_t, CV_32S
    * \param[out] segments when given: entry l describes label l of L_t (entry 0 unused)
    * Throws cuefusion::Error on a label map that is not CV_32S or masks of another size.
    */
  void merge (const cv::Mat& geometric, const std::vector<Instance>& instances, cv::Mat& fused,
              std::vector<SegmentInstance>* segments = nullptr) const;

private:
  InstanceGuidedMergeConfig config_;
};
/** \brief The masks alone as segments (the "masks" mode): label i + 1 for instance i,
  * the higher score where masks overlap, on pixels with a point in \a planes only (a
  * segment is a set of 3D points). \a segments, when given, describes each label.
  */
void
masksAsSegments (const std::vector<Instance>& instances, const SurfacePlanes& planes, cv::Mat& labels,
                 std::vector<SegmentInstance>* segments = nullptr);
}  // namespace segmentation
}  // namespace cuefusion
