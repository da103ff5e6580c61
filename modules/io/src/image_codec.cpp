// SPDX-License-Identifier: BSD-3-Clause
// PNG and JPEG through libpng and libjpeg, configured as OpenCV 4.6's imgcodecs configures
// them (see image_codec.h for why). Both libraries report errors by longjmp: every setjmp
// below sits in a small function whose own locals are plain C values, and the buffers it
// fills are allocated by its caller before, so no C++ object is left half-made by a jump.
#include "image_codec.h"

#include <opencv2/imgcodecs.hpp>  // the IMREAD_ and IMWRITE_ constants only
#include <opencv2/imgproc.hpp>

#include <png.h>
// jpeglib.h needs FILE and size_t declared first.
#include <cstdio>
#include <jpeglib.h>

#include <algorithm>
#include <csetjmp>
#include <cstring>
#include <memory>

namespace cuefusion
{
namespace io
{
namespace detail
{
namespace
{
// Larger images are refused before anything is allocated (a header can claim any size,
// and 510 KB of PNG can declare 16384 x 16384): 2^25 pixels is 8192 x 4096, twice a 4K
// colour camera's frame, at most 256 MB decoded (16-bit RGBA).
constexpr double kMaxPixels = double (1 << 25);

/** cv::imdecode's rule: the type decoded for an image stored as \a native. */
int
decodedType (int native, int flags)
{
  if (flags == cv::IMREAD_UNCHANGED)
    return native;
  const int depth = (flags & cv::IMREAD_ANYDEPTH) ? CV_MAT_DEPTH (native) : CV_8U;
  const bool color = (flags & cv::IMREAD_COLOR) || ((flags & cv::IMREAD_ANYCOLOR) && CV_MAT_CN (native) > 1);
  return CV_MAKETYPE (depth, color ? 3 : 1);
}

bool
littleEndian ()
{
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy (&first, &one, 1);
  return first == 1;
}

// ------------------------------------------------------------------------------ PNG

struct PngState
{
  const uchar* data = nullptr;
  std::size_t size = 0, position = 0;
  std::vector<uchar>* out = nullptr;
  char error[256] = "";
  std::string* warnings = nullptr;
};

void
pngError (png_structp png, png_const_charp message)
{
  auto* state = static_cast<PngState*> (png_get_error_ptr (png));
  std::snprintf (state->error, sizeof state->error, "libpng: %s", message);
  png_longjmp (png, 1);
}

void
pngWarning (png_structp png, png_const_charp message)
{
  auto* state = static_cast<PngState*> (png_get_error_ptr (png));
  if (state->warnings)
    *state->warnings += std::string (state->warnings->empty () ? "" : "; ") + "libpng warning: " + message;
}

void
pngRead (png_structp png, png_bytep out, png_size_t count)
{
  auto* state = static_cast<PngState*> (png_get_io_ptr (png));
  if (count > state->size - state->position)
    png_error (png, "the data ends early");
  std::memcpy (out, state->data + state->position, count);
  state->position += count;
}

void
pngWrite (png_structp png, png_bytep data, png_size_t count)
{
  auto* state = static_cast<PngState*> (png_get_io_ptr (png));
  state->out->insert (state->out->end (), data, data + count);
}

void
pngFlush (png_structp)
{
}

struct PngHeader
{
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0, transparent = 0;
};

bool
readPngHeader (png_structp png, png_infop info, PngHeader* h)
{
  if (setjmp (png_jmpbuf (png)))
    return false;
  png_read_info (png, info);
  png_get_IHDR (png, info, &h->width, &h->height, &h->bit_depth, &h->color_type, nullptr, nullptr, nullptr);
  png_bytep trans = nullptr;
  png_color_16p trans_values = nullptr;
  if (h->color_type == PNG_COLOR_TYPE_RGB || h->color_type == PNG_COLOR_TYPE_PALETTE)
    png_get_tRNS (png, info, &trans, &h->transparent, &trans_values);
  return true;
}

/** Reads the pixels into \a rows (allocated by the caller for \a row_bytes each) with
  * the transformations OpenCV's PngDecoder::readData sets. */
bool
readPngPixels (png_structp png, png_infop info, const PngHeader* h, int depth, int channels, png_bytepp rows,
               png_size_t row_bytes)
{
  if (setjmp (png_jmpbuf (png)))
    return false;
  if (depth == CV_8U && h->bit_depth == 16)
    png_set_strip_16 (png);
  else if (littleEndian ())
    png_set_swap (png);
  if (channels < 4)
    png_set_strip_alpha (png);
  else
    png_set_tRNS_to_alpha (png);
  if (h->color_type == PNG_COLOR_TYPE_PALETTE)
    png_set_palette_to_rgb (png);
  if ((h->color_type & PNG_COLOR_MASK_COLOR) == 0 && h->bit_depth < 8)
    png_set_expand_gray_1_2_4_to_8 (png);
  if ((h->color_type & PNG_COLOR_MASK_COLOR) && channels > 1)
    png_set_bgr (png);
  else if (channels > 1)
    png_set_gray_to_rgb (png);
  else
    png_set_rgb_to_gray (png, 1, 0.299, 0.587);
  png_set_interlace_handling (png);
  png_read_update_info (png, info);
  if (png_get_rowbytes (png, info) != row_bytes)
    png_error (png, "the decoded rows do not have the expected layout");
  png_read_image (png, rows);
  png_read_end (png, nullptr);
  return true;
}

/** The read structures of one PNG, destroyed with it. */
struct PngReader
{
  png_structp png = nullptr;
  png_infop info = nullptr;
  explicit PngReader (PngState* state)
  {
    png = png_create_read_struct (PNG_LIBPNG_VER_STRING, state, pngError, pngWarning);
    info = png ? png_create_info_struct (png) : nullptr;
    if (info)
      png_set_read_fn (png, state, pngRead);
  }
  ~PngReader () { png_destroy_read_struct (&png, &info, nullptr); }
  PngReader (const PngReader&) = delete;
  PngReader& operator= (const PngReader&) = delete;
};

cv::Mat
decodePng (const std::vector<uchar>& bytes, int flags, std::string& failure, std::string& warnings)
{
  PngState state;
  state.data = bytes.data ();
  state.size = bytes.size ();
  std::string png_warnings;
  state.warnings = &png_warnings;
  PngReader reader (&state);
  if (!reader.info)
  {
    failure = "libpng: out of memory";
    return cv::Mat ();
  }
  PngHeader header;
  if (!readPngHeader (reader.png, reader.info, &header))
  {
    failure = state.error;
    return cv::Mat ();
  }
  if (double (header.width) * header.height > kMaxPixels)
  {
    failure = "image of " + std::to_string (header.width) + "x" + std::to_string (header.height) +
              " pixels is larger than cuefusion reads (2^25 pixels)";
    return cv::Mat ();
  }
  int native_channels = 1;
  if (header.color_type == PNG_COLOR_TYPE_RGB || header.color_type == PNG_COLOR_TYPE_PALETTE)
    native_channels = header.transparent > 0 ? 4 : 3;
  else if (header.color_type == PNG_COLOR_TYPE_GRAY_ALPHA || header.color_type == PNG_COLOR_TYPE_RGB_ALPHA)
    native_channels = 4;
  const int type = decodedType (CV_MAKETYPE (header.bit_depth == 16 ? CV_16U : CV_8U, native_channels), flags);
  cv::Mat image (static_cast<int> (header.height), static_cast<int> (header.width), type);
  std::vector<png_bytep> rows (header.height);
  for (int y = 0; y < image.rows; ++y)
    rows[static_cast<std::size_t> (y)] = image.ptr (y);
  if (!readPngPixels (reader.png, reader.info, &header, image.depth (), image.channels (), rows.data (),
                      image.cols * image.elemSize ()))
  {
    failure = state.error;
    return cv::Mat ();
  }
  warnings += png_warnings;
  return image;
}

bool
writePngPixels (png_structp png, png_infop info, const cv::Mat* image, int level, int strategy, png_bytepp rows)
{
  if (setjmp (png_jmpbuf (png)))
    return false;
  if (level >= 0)
    png_set_compression_level (png, level);
  else  // OpenCV's default: fast, the Sub filter only
  {
    png_set_filter (png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level (png, 1);
  }
  png_set_compression_strategy (png, strategy);
  const int channels = image->channels ();
  png_set_IHDR (png, info, static_cast<png_uint_32> (image->cols), static_cast<png_uint_32> (image->rows),
                image->depth () == CV_8U ? 8 : 16,
                channels == 1 ? PNG_COLOR_TYPE_GRAY : channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_RGBA,
                PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info (png, info);
  png_set_bgr (png);
  if (littleEndian ())
    png_set_swap (png);
  png_write_image (png, rows);
  png_write_end (png, info);
  return true;
}

bool
encodePng (const cv::Mat& input, const std::vector<int>& params, std::vector<uchar>& out, std::string& failure)
{
  cv::Mat image = input;
  if (image.depth () != CV_8U && image.depth () != CV_16U)
    input.convertTo (image, CV_8U);  // as imencode does for a depth PNG cannot hold
  if (image.channels () == 2 || image.channels () > 4)
  {
    failure = "a PNG holds 1, 3 or 4 channels, not " + std::to_string (image.channels ());
    return false;
  }
  int level = -1, strategy = cv::IMWRITE_PNG_STRATEGY_RLE;
  for (std::size_t i = 0; i + 1 < params.size (); i += 2)
  {
    if (params[i] == cv::IMWRITE_PNG_COMPRESSION)
    {
      strategy = cv::IMWRITE_PNG_STRATEGY_DEFAULT;
      level = std::clamp (params[i + 1], 0, 9);
    }
    if (params[i] == cv::IMWRITE_PNG_STRATEGY)
      strategy = std::clamp (params[i + 1], 0, 4);
  }
  PngState state;
  state.out = &out;
  out.clear ();
  std::vector<png_bytep> rows (static_cast<std::size_t> (image.rows));
  for (int y = 0; y < image.rows; ++y)
    rows[static_cast<std::size_t> (y)] = const_cast<uchar*> (image.ptr (y));
  png_structp png = png_create_write_struct (PNG_LIBPNG_VER_STRING, &state, pngError, pngWarning);
  png_infop info = png ? png_create_info_struct (png) : nullptr;
  bool ok = info != nullptr;
  if (ok)
  {
    png_set_write_fn (png, &state, pngWrite, pngFlush);
    ok = writePngPixels (png, info, &image, level, strategy, rows.data ());
  }
  png_destroy_write_struct (&png, &info);
  if (!ok)
    failure = state.error[0] ? state.error : "libpng: out of memory";
  return ok;
}

// ----------------------------------------------------------------------------- JPEG

struct JpegErrors
{
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX + 16] = "";
  std::string* warnings = nullptr;
};

void
jpegError (j_common_ptr cinfo)
{
  auto* errors = reinterpret_cast<JpegErrors*> (cinfo->err);
  char text[JMSG_LENGTH_MAX];
  (*cinfo->err->format_message) (cinfo, text);
  std::snprintf (errors->message, sizeof errors->message, "libjpeg: %s", text);
  std::longjmp (errors->jump, 1);
}

void
jpegMessage (j_common_ptr cinfo)
{
  auto* errors = reinterpret_cast<JpegErrors*> (cinfo->err);
  char text[JMSG_LENGTH_MAX];
  (*cinfo->err->format_message) (cinfo, text);
  if (errors->warnings)
    *errors->warnings += std::string (errors->warnings->empty () ? "" : "; ") + "libjpeg warning: " + text;
}

void
useErrors (jpeg_error_mgr* manager)
{
  jpeg_std_error (manager);
  manager->error_exit = jpegError;
  manager->output_message = jpegMessage;
}

bool
readJpegHeader (jpeg_decompress_struct* cinfo, JpegErrors* errors, const std::vector<uchar>* bytes)
{
  if (setjmp (errors->jump))
    return false;
  jpeg_create_decompress (cinfo);
  jpeg_mem_src (cinfo, bytes->data (), static_cast<unsigned long> (bytes->size ()));
  jpeg_read_header (cinfo, TRUE);
  return true;
}

bool
readJpegPixels (jpeg_decompress_struct* cinfo, JpegErrors* errors, int channels, uchar** rows, int height)
{
  if (setjmp (errors->jump))
    return false;
  cinfo->out_color_space = channels == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  cinfo->out_color_components = channels;
  jpeg_start_decompress (cinfo);
  if (cinfo->output_components != channels || static_cast<int> (cinfo->output_height) != height)
  {
    std::snprintf (errors->message, sizeof errors->message, "libjpeg: the decoded rows are not what the header promised");
    return false;
  }
  while (cinfo->output_scanline < cinfo->output_height)
    jpeg_read_scanlines (cinfo, rows + cinfo->output_scanline, cinfo->output_height - cinfo->output_scanline);
  jpeg_finish_decompress (cinfo);
  return true;
}

cv::Mat
decodeJpeg (const std::vector<uchar>& bytes, int flags, std::string& failure, std::string& warnings)
{
  jpeg_decompress_struct cinfo{};
  JpegErrors errors;
  std::string jpeg_warnings;
  errors.warnings = &jpeg_warnings;
  useErrors (&errors.manager);
  cinfo.err = &errors.manager;
  const std::unique_ptr<jpeg_decompress_struct, void (*) (jpeg_decompress_struct*)> guard (
    &cinfo, [] (jpeg_decompress_struct* c) { jpeg_destroy_decompress (c); });
  if (!readJpegHeader (&cinfo, &errors, &bytes))
  {
    failure = errors.message;
    return cv::Mat ();
  }
  if (cinfo.num_components == 4)
  {
    failure = "a CMYK JPEG is not read (convert it to RGB)";
    return cv::Mat ();
  }
  if (double (cinfo.image_width) * cinfo.image_height > kMaxPixels)
  {
    failure = "image of " + std::to_string (cinfo.image_width) + "x" + std::to_string (cinfo.image_height) +
              " pixels is larger than cuefusion reads (2^25 pixels)";
    return cv::Mat ();
  }
  const int type = CV_MAKETYPE (CV_8U, CV_MAT_CN (decodedType (cinfo.num_components > 1 ? CV_8UC3 : CV_8UC1, flags)));
  cv::Mat image (static_cast<int> (cinfo.image_height), static_cast<int> (cinfo.image_width), type);
  std::vector<uchar*> rows (static_cast<std::size_t> (image.rows));
  for (int y = 0; y < image.rows; ++y)
    rows[static_cast<std::size_t> (y)] = image.ptr (y);
  if (!readJpegPixels (&cinfo, &errors, image.channels (), rows.data (), image.rows))
  {
    failure = errors.message;
    return cv::Mat ();
  }
  warnings += jpeg_warnings;
  return image;
}

bool
writeJpegPixels (jpeg_compress_struct* cinfo, JpegErrors* errors, const cv::Mat* image, int quality, unsigned char** buffer,
                 unsigned long* size)
{
  if (setjmp (errors->jump))
    return false;
  jpeg_create_compress (cinfo);
  jpeg_mem_dest (cinfo, buffer, size);
  cinfo->image_width = static_cast<JDIMENSION> (image->cols);
  cinfo->image_height = static_cast<JDIMENSION> (image->rows);
  cinfo->input_components = image->channels ();
  cinfo->in_color_space = image->channels () == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg_set_defaults (cinfo);
  cinfo->restart_interval = 0;
  jpeg_set_quality (cinfo, quality, TRUE);
  jpeg_start_compress (cinfo, TRUE);
  for (int y = 0; y < image->rows; ++y)
  {
    JSAMPROW row = const_cast<JSAMPROW> (image->ptr (y));
    jpeg_write_scanlines (cinfo, &row, 1);
  }
  jpeg_finish_compress (cinfo);
  return true;
}

bool
encodeJpeg (const cv::Mat& input, const std::vector<int>& params, std::vector<uchar>& out, std::string& failure)
{
  cv::Mat image = input;
  if (image.depth () != CV_8U)
    input.convertTo (image, CV_8U);
  if (image.channels () == 4)
    cv::cvtColor (image, image, cv::COLOR_BGRA2BGR);
  if (image.channels () != 1 && image.channels () != 3)
  {
    failure = "a JPEG holds 1 or 3 channels, not " + std::to_string (image.channels ());
    return false;
  }
  int quality = 95;
  for (std::size_t i = 0; i + 1 < params.size (); i += 2)
    if (params[i] == cv::IMWRITE_JPEG_QUALITY)
      quality = std::clamp (params[i + 1], 0, 100);
  quality = std::max (quality, 1);  // as OpenCV: 0 means the lowest
  jpeg_compress_struct cinfo{};
  JpegErrors errors;
  useErrors (&errors.manager);
  cinfo.err = &errors.manager;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  const bool ok = writeJpegPixels (&cinfo, &errors, &image, quality, &buffer, &size);
  jpeg_destroy_compress (&cinfo);
  if (ok)
    out.assign (buffer, buffer + size);
  std::free (buffer);
  if (!ok)
    failure = errors.message;
  return ok;
}
}  // namespace

cv::Mat
decodeImage (const std::vector<uchar>& bytes, int flags, std::string& failure, std::string& warnings)
{
  static const uchar png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size () >= 8 && std::memcmp (bytes.data (), png_signature, 8) == 0)
    return decodePng (bytes, flags, failure, warnings);
  if (bytes.size () >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff)
    return decodeJpeg (bytes, flags, failure, warnings);
  failure = "not a PNG or JPEG image";
  return cv::Mat ();
}

bool
encodeImage (const std::string& extension, const cv::Mat& image, const std::vector<int>& params, std::vector<uchar>& out,
             std::string& failure)
{
  std::string ext = extension;
  std::transform (ext.begin (), ext.end (), ext.begin (), [] (unsigned char c) { return static_cast<char> (std::tolower (c)); });
  if (image.empty ())
  {
    failure = "the image is empty";
    return false;
  }
  if (ext == ".png")
    return encodePng (image, params, out, failure);
  if (ext == ".jpg" || ext == ".jpeg")
    return encodeJpeg (image, params, out, failure);
  failure = "cuefusion writes images as .png or .jpg, not '" + extension + "'";
  return false;
}
}  // namespace detail
}  // namespace io
}  // namespace cuefusion
