// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/cpu_features.h>

#include <atomic>
#include <cstdlib>

namespace cuefusion
{
namespace
{
bool
initialSetting ()
{
  const char* off = std::getenv ("CUEFUSION_NO_AVX2");
  return cpuHasAvx2Fma () && (off == nullptr || *off == '\0' || *off == '0');
}

std::atomic<bool>&
enabledFlag ()
{
  static std::atomic<bool> flag{initialSetting ()};
  return flag;
}
}  // namespace

bool
cpuHasAvx2Fma ()
{
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  static const bool has = __builtin_cpu_supports ("avx2") && __builtin_cpu_supports ("fma");
  return has;
#else
  return false;
#endif
}

bool
vectorKernelsEnabled ()
{
  return enabledFlag ().load (std::memory_order_relaxed);
}

void
setVectorKernelsEnabled (bool enabled)
{
  enabledFlag ().store (enabled && cpuHasAvx2Fma (), std::memory_order_relaxed);
}
}  // namespace cuefusion
