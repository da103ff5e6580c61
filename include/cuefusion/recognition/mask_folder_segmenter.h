// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/instance_segmenter.h>

#include <map>
#include <string>
#include <vector>

namespace cuefusion
{
namespace recognition
{
/** \brief Instance masks another tool wrote: a folder of 16-bit instance-id PNGs (0 =
  * none) — ScanNet's instance-filt format, what Mask R-CNN, SAM & co. can export, and the
  * synthetic generator's detections/ — each optionally with a JSON of the same stem:
  * {"instances": [{"id": 3, "class_id": 41, "class_name": "cup", "score": 0.93}, …]}.
  *
  * A frame's masks are the file named like the frame (RGBDFrame::name), else the file
  * whose stem is the frame's index as a number ("12.png", "000012.png",
  * "frame-000012.png"). Without a JSON an instance has class −1 and score 1; with
  * \a class_names a JSON class_id without class_name is named from the list.
  */
class MaskFolderSegmenter : public InstanceSegmenter
{
public:
  /** \brief Throws cuefusion::Error when \a folder is not a readable folder. */
  explicit MaskFolderSegmenter (const std::string& folder, std::vector<std::string> class_names = {});

  bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) override;
  std::string name () const override { return "masks:" + folder_; }

  /** \brief The mask file used for \a frame, "" when there is none. */
  std::string maskPathFor (const RGBDFrame& frame) const;

  /** \brief Reads one id PNG (and its JSON when present) at \a size. */
  std::vector<Instance> readMasks (const std::string& png, cv::Size size) const
  {
    return readInstanceMasks (png, size, class_names_);
  }

  /** \brief Reads one 16-bit instance-id PNG and, when there is one, the JSON of the
    * same stem; the image must be \a size. Throws cuefusion::Error naming the file.
    */
  static std::vector<Instance> readInstanceMasks (const std::string& png, cv::Size size,
                                                  const std::vector<std::string>& class_names = {});

private:
  std::string folder_;
  std::vector<std::string> class_names_;
  std::map<std::string, std::string> by_stem_;  ///< stem → path
  std::map<long, std::string> by_number_;       ///< trailing number of the stem → path
};
}  // namespace recognition
}  // namespace cuefusion
