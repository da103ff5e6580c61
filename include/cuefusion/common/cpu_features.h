// SPDX-License-Identifier: BSD-3-Clause
#pragma once

namespace cuefusion
{
/** \brief Whether the hand-vectorised AVX2 + FMA kernels run instead of their scalar
  * versions. There are six: TSDF integration (integration.cpp), ICP accumulation
  * (projective_icp.cpp), the raycast's Newton steps (raycast.cpp), the pyramid's
  * downsampling (preprocessing.cpp), the noise-adaptive bilateral filter
  * (depth_smoothing.cpp) and the propagation's per-pixel tests (segment_propagation.cpp).
  * Plain loops the compiler vectorises (the normal map, normal_map.cpp; the edge
  * operators, edge_maps.cpp) are built twice instead (CUEFUSION_AVX2_CLONES in avx2.h) and
  * follow the CPU, not this switch.
  *
  * The project is built for baseline x86-64 (SSE2) so that one binary runs on any x86-64
  * machine and its Eigen types keep the layout Debian's PCL was compiled with (-march
  * flags on our side alone would change the alignment of fixed-size Eigen members, an ABI
  * break). The few loops that dominate a frame are written a second time with AVX2
  * intrinsics in functions compiled for that target alone and chosen at run time: true
  * when the CPU has AVX2 and FMA and setVectorKernelsEnabled(false) was not called (or
  * CUEFUSION_NO_AVX2 is set in the environment).
  */
bool
vectorKernelsEnabled ();

/** \brief Turns the AVX2 kernels off (false) or back on where the CPU has them (true);
  * the tests use it to compare both paths. Not meant to be flipped while a frame runs.
  */
void
setVectorKernelsEnabled (bool enabled);

/** \brief Whether this CPU has AVX2 and FMA. */
bool
cpuHasAvx2Fma ();
}  // namespace cuefusion
