// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cstdint>
#include <string>

namespace cuefusion
{
namespace recognition
{
/** \brief Largest ONNX file cuefusion loads (1 GiB; protobuf itself stops at 2 GiB). */
constexpr std::uint64_t kMaxOnnxFileBytes = std::uint64_t{1} << 30;

/** \brief Checks an ONNX file's structure before OpenCV parses it, and throws
  * cuefusion::Error naming \a path when it is not sound.
  *
  * OpenCV 4.6's ONNX importer trusts the file: a tensor whose dims promise more values
  * than it carries (an initializer of dims 2^40 and no data) or one whose data lives in
  * external files makes it read past its buffers or allocate without bound, and the
  * process crashes. This walks the protobuf wire format of the model's graph (and every
  * graph nested in a node's attributes): every length within the file, every tensor
  * (initializers, sparse initializers, attribute tensors) with non-negative dims whose
  * product is below 2^31 values and exactly matches the values it stores, no external
  * data, nesting at most 16 graphs deep, the file at most kMaxOnnxFileBytes.
  */
void
checkOnnxModel (const std::string& path);

/** \brief The same check on the file's bytes; \a source names it in the error. */
void
checkOnnxModelBytes (const std::string& bytes, const std::string& source);
}  // namespace recognition
}  // namespace cuefusion
