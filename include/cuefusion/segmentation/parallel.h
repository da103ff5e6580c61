// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/parallel.h>

namespace cuefusion
{
namespace segmentation
{
/** The project's one thread pool (see common/parallel.h). */
using cuefusion::parallelFor;
}  // namespace segmentation
}  // namespace cuefusion
