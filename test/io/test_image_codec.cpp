// SPDX-License-Identifier: BSD-3-Clause
// cuefusion reads and writes PNG and JPEG through libpng and libjpeg itself
// (modules/io/src/image_codec.h); OpenCV's imgcodecs is the reference it must agree with,
// pixel for pixel when reading and byte for byte when writing.
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <string>
#include <vector>

using namespace cuefusion;
using cuefusion::test::TempDir;

namespace
{
/** Content with smooth shading, edges and noise: every filter and DCT path gets work. */
cv::Mat
testImage (int type)
{
  cv::Mat image (61, 83, type);  // odd sizes: partial JPEG blocks, unaligned rows
  cv::RNG rng (7);
  rng.fill (image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH (type) == CV_16U ? 65535 : 255);
  cv::Mat smooth;
  cv::GaussianBlur (image, smooth, cv::Size (9, 9), 3.0);
  cv::rectangle (smooth, cv::Rect (10, 12, 30, 20), cv::Scalar::all (CV_MAT_DEPTH (type) == CV_16U ? 50000 : 200), -1);
  cv::circle (smooth, cv::Point (60, 40), 12, cv::Scalar (10, 120, 240, 90), -1);
  return smooth;
}

/** PNG's chunk checksum (CRC-32, ISO 3309), so a test can forge a well-formed header. */
std::uint32_t
crc32 (const std::string& bytes)
{
  std::uint32_t crc = 0xffffffffu;
  for (const char ch : bytes)
  {
    crc ^= static_cast<unsigned char> (ch);
    for (int k = 0; k < 8; ++k)
      crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xffffffffu;
}

bool
samePixels (const cv::Mat& a, const cv::Mat& b)
{
  return a.type () == b.type () && a.size () == b.size () && cv::norm (a, b, cv::NORM_INF) == 0.0;
}
}  // namespace

TEST (ImageCodec, WritesTheBytesOpenCvWrites)
{
  TempDir dir;
  struct Case
  {
    int type;
    std::string ext;
    std::vector<int> params;
  };
  const std::vector<Case> cases = {
    {CV_8UC1, ".png", {}},  {CV_8UC3, ".png", {}},  {CV_8UC4, ".png", {}},
    {CV_16UC1, ".png", {}}, {CV_16UC3, ".png", {}}, {CV_16UC1, ".png", {cv::IMWRITE_PNG_COMPRESSION, 9}},
    {CV_8UC3, ".png", {cv::IMWRITE_PNG_COMPRESSION, 0}},
    {CV_8UC3, ".jpg", {}},  {CV_8UC3, ".jpg", {cv::IMWRITE_JPEG_QUALITY, 95}},
    {CV_8UC3, ".jpeg", {cv::IMWRITE_JPEG_QUALITY, 40}}, {CV_8UC1, ".jpg", {cv::IMWRITE_JPEG_QUALITY, 80}},
  };
  for (const Case& c : cases)
  {
    const cv::Mat image = testImage (c.type);
    const std::string path = dir / ("out" + c.ext);
    io::writeImageAtomic (path, image, c.params);
    std::vector<uchar> expected;
    ASSERT_TRUE (cv::imencode (c.ext, image, expected, c.params));
    const std::string written = test::readFile (path);
    EXPECT_EQ (written, std::string (expected.begin (), expected.end ()))
      << "type " << c.type << " as " << c.ext << " with " << c.params.size () / 2 << " parameter(s)";
  }
  // What neither format holds is refused by name, not written.
  test::expectError ([&] { io::writeImageAtomic (dir / "two.png", cv::Mat (4, 4, CV_8UC2, cv::Scalar (1, 2))); }, "two.png",
                     "2");
  test::expectError ([&] { io::writeImageAtomic (dir / "x.tiff", testImage (CV_8UC3)); }, "x.tiff", ".tiff");
  EXPECT_FALSE (boost::filesystem::exists (dir / "two.png"));
}

TEST (ImageCodec, ReadsThePixelsOpenCvReads)
{
  TempDir dir;
  // Files in the flavours datasets hold, written by OpenCV (and one 1-bit PNG).
  struct File
  {
    std::string name;
    int type;
    std::vector<int> params;
  };
  const std::vector<File> files = {
    {"gray8.png", CV_8UC1, {}},     {"bgr8.png", CV_8UC3, {}},   {"bgra8.png", CV_8UC4, {}},
    {"depth16.png", CV_16UC1, {}},  {"bgr16.png", CV_16UC3, {}}, {"bgra16.png", CV_16UC4, {}},
    {"bilevel.png", CV_8UC1, {cv::IMWRITE_PNG_BILEVEL, 1}},
    {"color.jpg", CV_8UC3, {cv::IMWRITE_JPEG_QUALITY, 90}}, {"gray.jpg", CV_8UC1, {}},
    {"progressive.jpg", CV_8UC3, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
  };
  const std::vector<int> flag_sets = {cv::IMREAD_COLOR, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, cv::IMREAD_UNCHANGED,
                                      cv::IMREAD_GRAYSCALE, cv::IMREAD_ANYDEPTH};
  for (const File& f : files)
  {
    const std::string path = dir / f.name;
    ASSERT_TRUE (cv::imwrite (path, testImage (f.type), f.params));
    for (const int flags : flag_sets)
    {
      const cv::Mat expected = cv::imread (path, flags | cv::IMREAD_IGNORE_ORIENTATION);
      const cv::Mat got = io::readImage (path, flags);
      EXPECT_TRUE (samePixels (got, expected)) << f.name << " with flags " << flags << ": type " << got.type () << " vs "
                                               << expected.type ();
    }
  }
  // The hand-made flavours kept for the fuzzer (palette with transparency, 16-bit gray with
  // alpha, a 1-bit interlaced PNG, broken and oversized files): where OpenCV reads one,
  // the same pixels; where it refuses one, an Error.
  const std::string fuzz_inputs = std::string (CUEFUSION_TEST_SOURCE_DIR) + "/data/fuzz/image";
  int compared = 0;
  for (boost::filesystem::directory_iterator it (fuzz_inputs), end; it != end; ++it)
    for (const int flags : flag_sets)
    {
      const std::string path = it->path ().string ();
      cv::Mat expected;
      try
      {
        expected = cv::imread (path, flags | cv::IMREAD_IGNORE_ORIENTATION);
      }
      catch (const cv::Exception&)  // OpenCV refuses oversized headers by an assertion
      {
      }
      if (expected.empty ())
        EXPECT_THROW (io::readImage (path, flags), Error) << path << " with flags " << flags;
      else
      {
        EXPECT_TRUE (samePixels (io::readImage (path, flags), expected)) << path << " with flags " << flags;
        ++compared;
      }
    }
  EXPECT_GE (compared, 2 * static_cast<int> (flag_sets.size ()));  // the palette and gray-alpha files
  // Not an image, another format, a corrupt PNG: one error naming the file each.
  test::writeFile (dir / "text.png", "definitely not an image");
  test::expectError ([&] { io::readImage (dir / "text.png", cv::IMREAD_COLOR); }, "text.png", "not a PNG or JPEG");
  cv::imwrite (dir / "image.bmp", testImage (CV_8UC3));
  test::expectError ([&] { io::readImage (dir / "image.bmp", cv::IMREAD_COLOR); }, "image.bmp", "not a PNG or JPEG");
  std::string bytes = test::readFile (dir / "bgr8.png");
  bytes[bytes.find ("IDAT") + 12] ^= 0x55;
  test::writeFile (dir / "corrupt.png", bytes);
  test::expectError ([&] { io::readImage (dir / "corrupt.png", cv::IMREAD_COLOR); }, "corrupt.png", "libpng");
  // Headers claiming more pixels than any frame (65536², and 16384² — 2 to 9.5 GB decoded
  // from a 510 KB file before): refused before anything is allocated.
  const std::string gray = test::readFile (dir / "gray8.png");
  for (const unsigned char side : {0x01, 0x00})
  {
    bytes = gray;
    const unsigned char second = side ? 0x00 : 0x40;  // 0x00010000 = 65536, 0x00004000 = 16384
    const unsigned char huge[8] = {0x00, side, second, 0x00, 0x00, side, second, 0x00};
    bytes.replace (16, 8, reinterpret_cast<const char*> (huge), 8);
    const std::uint32_t crc = crc32 (bytes.substr (12, 17));  // "IHDR" and its 13 bytes
    for (int k = 0; k < 4; ++k)
      bytes[static_cast<std::size_t> (29 + k)] = static_cast<char> ((crc >> (24 - 8 * k)) & 0xffu);
    test::writeFile (dir / "huge.png", bytes);
    test::expectError ([&] { io::readImage (dir / "huge.png", cv::IMREAD_COLOR); }, "huge.png", "larger");
  }
}
