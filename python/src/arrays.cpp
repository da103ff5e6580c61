// SPDX-License-Identifier: BSD-3-Clause
#include "arrays.h"

#include <cuefusion/common/exceptions.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>

namespace cuefusion
{
namespace python
{
namespace
{
std::string
shapeText (const py::array& a)
{
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim (); ++k)
    s += (k ? ", " : "") + std::to_string (a.shape (k));
  return s + (a.ndim () == 1 ? ",)" : ")");
}

std::string
dtypeText (const py::array& a)
{
  return py::str (a.dtype ()).cast<std::string> ();
}

/** \a object as an array, C-contiguous (a strided view is refused: the copy it needs
  * would be silent); ValueError naming \a name otherwise. */
py::array
contiguousArray (const py::object& object, const std::string& name)
{
  if (!py::isinstance<py::array> (object))
    throw py::value_error (name + " must be a numpy array, not " + py::str (py::type::of (object).attr ("__name__")).cast<std::string> ());
  py::array a = py::reinterpret_borrow<py::array> (object);
  if (!(a.flags () & py::array::c_style))
    throw py::value_error (name + " must be C-contiguous (numpy.ascontiguousarray makes it so)");
  return a;
}

/** A numeric array of \a rows × \a cols as doubles, every entry finite. */
std::vector<double>
finiteMatrix (const py::object& object, const std::string& name, py::ssize_t rows, py::ssize_t cols)
{
  if (!py::isinstance<py::array> (object) && !py::isinstance<py::sequence> (object))
    throw py::value_error (name + " must be a " + std::to_string (rows) + "x" + std::to_string (cols) + " array");
  py::array a = py::array::ensure (object);
  if (!a || a.ndim () != 2 || a.shape (0) != rows || a.shape (1) != cols)
    throw py::value_error (name + " must be a " + std::to_string (rows) + "x" + std::to_string (cols) + " array, got shape " +
                           (a ? shapeText (a) : std::string ("?")));
  const char kind = a.dtype ().kind ();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::value_error (name + " must hold numbers, got dtype " + dtypeText (a));
  const py::array_t<double, py::array::c_style | py::array::forcecast> d (a);
  std::vector<double> values (d.data (), d.data () + rows * cols);
  for (const double v : values)
    if (!std::isfinite (v))
      throw py::value_error (name + " holds a value that is not finite (NaN or infinite)");
  return values;
}
}  // namespace

void
raiseOSError (const std::string& message)
{
  PyErr_SetString (PyExc_OSError, message.c_str ());
  throw py::error_already_set ();
}

cv::Mat
depthFromArray (const py::array& depth, double depth_scale)
{
  const py::array a = contiguousArray (depth, "depth");
  if (a.ndim () != 2 || a.shape (0) < 1 || a.shape (1) < 1)
    throw py::value_error ("depth must be an HxW image, got shape " + shapeText (a));
  const int rows = static_cast<int> (a.shape (0)), cols = static_cast<int> (a.shape (1));
  cv::Mat out (rows, cols, CV_32F);
  if (a.dtype ().is (py::dtype::of<float> ()))
    std::memcpy (out.data, a.data (), out.total () * sizeof (float));
  else if (a.dtype ().is (py::dtype::of<std::uint16_t> ()))
  {
    if (!(depth_scale > 0.0) || !std::isfinite (depth_scale))
      throw py::value_error ("depth_scale must be a positive number (units per metre), got " + std::to_string (depth_scale));
    cv::Mat (rows, cols, CV_16U, const_cast<void*> (a.data ())).convertTo (out, CV_32F, 1.0 / depth_scale);
  }
  else
    throw py::value_error ("depth must be float32 (metres) or uint16 (with depth_scale), got dtype " + dtypeText (a));
  return out;
}

cv::Mat
colorFromArray (const py::object& color, cv::Size size)
{
  if (color.is_none ())
    return cv::Mat ();
  const py::array a = contiguousArray (color, "color");
  if (a.ndim () != 3 || a.shape (0) != size.height || a.shape (1) != size.width || a.shape (2) != 3)
    throw py::value_error ("color must be an HxWx3 RGB image of the depth's size (" + std::to_string (size.height) + ", " +
                           std::to_string (size.width) + ", 3), got shape " + shapeText (a));
  if (!a.dtype ().is (py::dtype::of<std::uint8_t> ()))
    throw py::value_error ("color must be uint8, got dtype " + dtypeText (a));
  cv::Mat bgr;
  cv::cvtColor (cv::Mat (size, CV_8UC3, const_cast<void*> (a.data ())), bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

PinholeCamera
cameraFromArray (const py::object& K, cv::Size size)
{
  const std::vector<double> k = finiteMatrix (K, "K", 3, 3);
  if (!(k[0] > 0.0) || !(k[4] > 0.0))
    throw py::value_error ("K must have positive focal lengths fx = K[0, 0] and fy = K[1, 1]");
  return PinholeCamera (k[0], k[4], k[2], k[5], size.width, size.height);
}

Eigen::Isometry3d
poseFromArray (const py::object& pose, const std::string& name)
{
  const std::vector<double> m = finiteMatrix (pose, name, 4, 4);
  Eigen::Matrix4d matrix;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      matrix (r, c) = m[static_cast<std::size_t> (r * 4 + c)];
  const Eigen::Matrix3d R = matrix.topLeftCorner<3, 3> ();
  if ((R.transpose () * R - Eigen::Matrix3d::Identity ()).norm () > 1e-4 || R.determinant () < 0.0 ||
      (matrix.row (3) - Eigen::RowVector4d (0, 0, 0, 1)).norm () > 1e-9)
    throw py::value_error (name + " must be a rigid transform (a rotation and a translation, last row 0 0 0 1)");
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity ();
  out.matrix () = matrix;
  return out;
}

namespace
{
Instance
instanceFromTuple (const py::handle& item, cv::Size size, std::size_t k)
{
  const std::string name = "masks[" + std::to_string (k) + "]";
  if (!py::isinstance<py::tuple> (item) && !py::isinstance<py::list> (item))
    throw py::value_error (name + " must be a tuple (mask, score, class name)");
  const py::sequence t = py::reinterpret_borrow<py::sequence> (item);
  if (t.size () < 1 || t.size () > 3)
    throw py::value_error (name + " must be a tuple (mask, score, class name)");
  const py::array a = contiguousArray (t[0], name + "'s mask");
  if (a.ndim () != 2 || a.shape (0) != size.height || a.shape (1) != size.width)
    throw py::value_error (name + "'s mask must be HxW as the depth, got shape " + shapeText (a));
  if (!a.dtype ().is (py::dtype::of<bool> ()) && !a.dtype ().is (py::dtype::of<std::uint8_t> ()))
    throw py::value_error (name + "'s mask must be bool or uint8, got dtype " + dtypeText (a));
  Instance instance;
  const cv::Mat view (size, CV_8U, const_cast<void*> (a.data ()));
  if (a.dtype ().is (py::dtype::of<bool> ()))
    instance.mask = view.clone ();  // numpy's bool is one byte, 0 or 1: a copy is the mask
  else
    cv::min (view, 1, instance.mask);  // one pass: any non-zero byte becomes 1
  instance.box = cv::boundingRect (instance.mask);
  if (t.size () >= 2)
  {
    double score = 0.0;
    try
    {
      score = t[1].cast<double> ();
    }
    catch (const py::cast_error&)
    {
      throw py::value_error (name + "'s score must be a number in [0, 1]");
    }
    if (!(score >= 0.0 && score <= 1.0))
      throw py::value_error (name + "'s score must lie in [0, 1], got " + std::to_string (score));
    instance.score = static_cast<float> (score);
  }
  if (t.size () == 3 && !t[2].is_none ())
  {
    if (!py::isinstance<py::str> (t[2]))
      throw py::value_error (name + "'s class name must be a string or None");
    instance.class_name = t[2].cast<std::string> ();
  }
  return instance;
}
}  // namespace

bool
instancesFromPython (const py::object& masks, cv::Size size, std::vector<Instance>& instances)
{
  instances.clear ();
  if (masks.is_none ())
    return false;
  if (py::isinstance<py::array> (masks))
  {
    const py::array a = contiguousArray (masks, "masks");
    if (a.ndim () != 2 || a.shape (0) != size.height || a.shape (1) != size.width)
      throw py::value_error ("masks must be an HxW id image of the depth's size, got shape " + shapeText (a));
    const char kind = a.dtype ().kind ();
    if ((kind != 'i' && kind != 'u') || a.itemsize () > 8)
      throw py::value_error ("masks as an id image must be of an integer dtype, got " + dtypeText (a));
    const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> ids (a);
    cv::Mat id_image (size, CV_32S);
    for (int i = 0; i < size.area (); ++i)
    {
      const std::int64_t id = ids.data ()[i];
      if (id < 0 || id > 65535)
        throw py::value_error ("masks ids must lie in [0, 65535] (0 = none), got " + std::to_string (id));
      id_image.ptr<std::int32_t> ()[i] = static_cast<std::int32_t> (id);
    }
    instances = instancesFromIdImage (id_image);
    return true;
  }
  if (!py::isinstance<py::list> (masks) && !py::isinstance<py::tuple> (masks))
    throw py::value_error ("masks must be None, an HxW id image or a list of (mask, score, class name)");
  std::size_t k = 0;
  for (const py::handle item : masks)
    instances.push_back (instanceFromTuple (item, size, k++));
  return true;
}

RGBDFrame
frameFromArrays (const py::array& depth, const py::object& color, const py::object& K, double depth_scale)
{
  RGBDFrame frame;
  frame.depth = depthFromArray (depth, depth_scale);
  frame.color = colorFromArray (color, frame.depth.size ());
  frame.camera = cameraFromArray (K, frame.depth.size ());
  return frame;
}

py::array
arrayFromMat (const cv::Mat& image)
{
  std::string format;
  switch (image.depth ())
  {
  case CV_8U: format = py::format_descriptor<std::uint8_t>::format (); break;
  case CV_16U: format = py::format_descriptor<std::uint16_t>::format (); break;
  case CV_32S: format = py::format_descriptor<std::int32_t>::format (); break;
  case CV_32F: format = py::format_descriptor<float>::format (); break;
  case CV_64F: format = py::format_descriptor<double>::format (); break;
  default: throw Error ("arrayFromMat", "unsupported image type");
  }
  const cv::Mat m = image.isContinuous () ? image : image.clone ();
  std::vector<py::ssize_t> shape = {m.rows, m.cols};
  if (m.channels () > 1)
    shape.push_back (m.channels ());
  py::array out (py::dtype (format), shape);
  std::memcpy (out.mutable_data (), m.data, m.total () * m.elemSize ());
  return out;
}

py::array
rgbArrayFromBgr (const cv::Mat& bgr)
{
  if (bgr.empty ())
    return arrayFromMat (cv::Mat (0, 0, CV_8UC3));
  cv::Mat rgb;
  cv::cvtColor (bgr, rgb, cv::COLOR_BGR2RGB);
  return arrayFromMat (rgb);
}

py::array
arrayFromPose (const Eigen::Isometry3d& pose)
{
  py::array_t<double> out ({4, 4});
  auto m = out.mutable_unchecked<2> ();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      m (r, c) = pose.matrix () (r, c);
  return out;
}

py::array
arrayFromCamera (const PinholeCamera& camera)
{
  py::array_t<double> out ({3, 3});
  auto m = out.mutable_unchecked<2> ();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      m (r, c) = 0.0;
  m (0, 0) = camera.fx;
  m (1, 1) = camera.fy;
  m (0, 2) = camera.cx;
  m (1, 2) = camera.cy;
  m (2, 2) = 1.0;
  return out;
}
}  // namespace python
}  // namespace cuefusion
