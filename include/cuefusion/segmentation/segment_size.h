// SPDX-License-Identifier: BSD-3-Clause
#pragma once

namespace cuefusion
{
namespace segmentation
{
/** Frame segments of fewer pixels are noise, not objects: the edge labelling relabels such
  * components 0 (EdgeLabelingConfig::min_segment_size) and the propagation gives them no
  * label (SegmentPropagationConfig::min_segment_size). Both default to this one value. */
constexpr int kMinSegmentPixels = 50;
}  // namespace segmentation
}  // namespace cuefusion
