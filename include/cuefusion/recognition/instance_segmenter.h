// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/common/rgbd_frame.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace recognition
{
/** \brief A mask source's stage timings (common/instance.h, where run records take them from). */
using SegmenterTimings = cuefusion::SegmenterTimings;

/** \brief A source of instance masks for a frame (thesis §4.2.1.2): a network run on the
  * colour image, or masks some other tool wrote. Sources are swappable; the pipeline and
  * `cuefusion segment-frame` only see this interface.
  */
class InstanceSegmenter
{
public:
  using Ptr = std::shared_ptr<InstanceSegmenter>;
  virtual ~InstanceSegmenter () = default;

  /** \brief Instances of \a frame (masks at the frame's size, CV_8U). Returns false when
    * the source has nothing for this frame (e.g. no mask file): the frame is then
    * segmented by geometry alone. Throws cuefusion::Error on unreadable input.
    */
  virtual bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) = 0;

  /** \brief Short description for logs, e.g. "onnx:yolov5s-seg.onnx". */
  virtual std::string name () const = 0;

  /** \brief The stages of the last segment() call, on the thread that made it. */
  virtual SegmenterTimings lastTimings () const { return {}; }

  /** \brief Index of the frame the masks of the last segment() call were computed on, for
    * sources that hand out an earlier frame's masks (AsynchronousSegmenter,
    * PeriodicSegmenter); none for those whose masks are always the frame's own. */
  virtual std::optional<std::size_t> lastResultFrame () const { return std::nullopt; }
};

/** \brief Class names, one per line (blank lines and surrounding spaces dropped), e.g.
  * data/classes/coco.names. Throws cuefusion::Error naming the file when it cannot be
  * read or holds no name.
  */
std::vector<std::string>
readClassNames (const std::string& path);

/** \brief <dataDirectory()>/classes/coco.names (see cuefusion::dataDirectory). */
std::string
defaultClassNamesPath ();
}  // namespace recognition
}  // namespace cuefusion
