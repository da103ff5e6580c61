// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/io/mesh_io.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <set>

namespace cuefusion
{
namespace visualization
{
/** \brief What a labelled mesh looks like from one camera. */
struct MeshView
{
  cv::Mat labels;   ///< CV_32S segment label per pixel (0 = background or unlabelled)
  cv::Mat depth;    ///< CV_32F z in metres (0 = background)
  cv::Mat image;    ///< CV_8UC3 BGR, shaded (labels coloured by labelColor, else vertex colour)
};

struct MeshRasterizerConfig
{
  float near_plane = 0.05f;               ///< metres; triangles crossing it are dropped
  bool color_by_label = true;             ///< else the mesh's vertex colours
  /** Skip triangles seen from behind (by their vertex normals where the mesh has them,
    * else by winding: marching-cubes faces wind counter-clockwise around the normal that
    * points into free space): walls between an outside viewpoint and a room's contents
    * disappear, and the far walls are seen from inside, as in a dollhouse view. */
  bool cull_back_faces = false;
  cv::Vec3b background{255, 255, 255};    ///< BGR
  void validate () const;
};

/** \brief Software z-buffer rendering of a triangle mesh (pinhole camera, pixel centres at
  * integer coordinates like PinholeCamera::project). Depth is interpolated perspective-
  * correctly; each pixel takes the label of the triangle corner nearest to it, so label
  * borders inside a triangle fall where the TSDF's nearest-voxel labels put them.
  *
  * The project renders itself rather than through VTK: this works with no display, no
  * OpenGL and no Xvfb, and gives exact label ids per pixel (an OpenGL colour buffer would
  * need colour→id decoding and no anti-aliasing). Shading is Lambertian with a headlight,
  * from the mean of each triangle's vertex normals where the mesh has them (a TSDF
  * mesh's gradient normals; a noisy surface's face normals shade it as grain), else from
  * its face normal; back faces are culled by the same normal.
  */
class MeshRasterizer
{
public:
  explicit MeshRasterizer (const MeshRasterizerConfig& config = MeshRasterizerConfig ());

  /** \param[in] pose camera-to-world */
  MeshView render (const io::TriangleMesh& mesh, const PinholeCamera& camera, const Eigen::Isometry3d& pose) const;

private:
  MeshRasterizerConfig config_;
};

/** \brief Camera poses on a circle around \a mesh looking at its centre from 30° above
  * the plane orthogonal to \a up, for overview renders; \a views ≥ 1. The circle's
  * radius fits the sphere around the box of the vertices labelled with one of \a focus
  * (a run's objects, so that a room's floor and walls do not set the framing; when \a
  * focus is empty or none of its labels is in the mesh, every labelled vertex; all
  * vertices when none is labelled), from the 2nd to the 98th percentile on each axis so
  * that a few stray surfaces far off do not set it either, into \a camera's narrower
  * field of view.
  */
std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>
orbitViews (const io::TriangleMesh& mesh, const PinholeCamera& camera, int views,
            const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ (), const std::set<std::uint32_t>& focus = {});

/** \brief \a views of a run's own camera poses (camera-to-world), evenly spaced along
  * them: the first, the last and between (the middle one for a single view). A room
  * seen from where the camera stood, from inside, as a user knows it; orbitViews looks at
  * it from outside. Throws ParameterError when \a views < 1 or \a poses is empty.
  */
std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>
cameraViews (const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& poses, int views);

/** \brief The world's up direction as a hand-held or robot camera sees it: the mean of
  * the cameras' image-up axes (−y of each camera-to-world pose), normalised; world z
  * when \a poses is empty or the mean vanishes. Datasets differ (ICL-NUIM and ScanNet
  * are y-up or z-up), the cameras' orientation does not.
  */
Eigen::Vector3d
upFromCameras (const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& poses);
}  // namespace visualization
}  // namespace cuefusion
