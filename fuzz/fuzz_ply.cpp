// SPDX-License-Identifier: BSD-3-Clause
// The PLY reader of eval and render: counts against the file size, lists, indices.
#include "fuzz_input.h"

#include <cuefusion/io/mesh_io.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "mesh.ply");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    const cuefusion::io::TriangleMesh mesh = cuefusion::io::readMeshPLY (path);
    for (const auto& t : mesh.triangles)  // what the rasterizer relies on
      for (int k = 0; k < 3; ++k)
        if (t[k] < 0 || static_cast<std::size_t> (t[k]) >= mesh.vertices.size ())
          std::abort ();
  });
  return 0;
}
