// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <string>

namespace cuefusion
{
namespace io
{
/** \brief Reads intrinsics from any of the layouts the datasets use:
  * - Open3D / Redwood JSON: {"width", "height", "intrinsic_matrix": 9 numbers, column-major}
  * - 3×3 K (7-Scenes camera-intrinsics.txt) or 4×4 (ScanNet intrinsic_*.txt), row-major
  * - one line "fx fy cx cy" or "fx fy cx cy width height"
  *
  * Files without an image size leave width = height = 0; the grabber then takes the
  * size from the first depth image. Throws cuefusion::Error naming the file otherwise.
  */
PinholeCamera
readIntrinsics (const std::string& path);

/** \brief Open3D / Redwood camera_intrinsics.json. */
void
writeIntrinsicsJson (const std::string& path, const PinholeCamera& camera);

/** \brief Row-major matrix text: 3×3 (7-Scenes) or 4×4 (ScanNet). */
void
writeIntrinsicsMatrix (const std::string& path, const PinholeCamera& camera, int rows);

/** \brief One line "fx fy cx cy width height". */
void
writeIntrinsicsLine (const std::string& path, const PinholeCamera& camera);
}  // namespace io
}  // namespace cuefusion
