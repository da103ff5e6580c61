// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <cctype>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace recognition
{
namespace
{
/** The number a stem ends with ("frame-000012" → 12), −1 when it ends with no digit. */
long
trailingNumber (const std::string& stem)
{
  std::size_t start = stem.size ();
  while (start > 0 && std::isdigit (static_cast<unsigned char> (stem[start - 1])))
    --start;
  if (start == stem.size () || stem.size () - start > 12)
    return -1;
  return std::stol (stem.substr (start));
}
}  // namespace

MaskFolderSegmenter::MaskFolderSegmenter (const std::string& folder, std::vector<std::string> class_names)
  : folder_ (folder), class_names_ (std::move (class_names))
{
  boost::system::error_code ec;
  if (!fs::is_directory (folder, ec))
    throw Error (folder, "mask folder does not exist or is not a folder");
  for (fs::directory_iterator it (folder, ec), end; !ec && it != end; it.increment (ec))
    if (it->path ().extension () == ".png")
    {
      const std::string stem = it->path ().stem ().string ();
      by_stem_[stem] = it->path ().string ();
      const long number = trailingNumber (stem);
      if (number >= 0)
        by_number_.emplace (number, it->path ().string ());  // the first name wins a clash
    }
  if (ec)
    throw Error (folder, "cannot list mask folder: " + ec.message ());
}

std::string
MaskFolderSegmenter::maskPathFor (const RGBDFrame& frame) const
{
  if (!frame.name.empty ())
  {
    const auto it = by_stem_.find (frame.name);
    if (it != by_stem_.end ())
      return it->second;
  }
  const auto it = by_number_.find (static_cast<long> (frame.index));
  return it == by_number_.end () ? std::string () : it->second;
}

std::vector<Instance>
MaskFolderSegmenter::readInstanceMasks (const std::string& png, cv::Size size, const std::vector<std::string>& class_names)
{
  const cv::Mat ids = io::readLabelImage (png);
  if (ids.size () != size)
    throw Error (png, "mask image is " + std::to_string (ids.cols) + "x" + std::to_string (ids.rows) + ", the frame " +
                        std::to_string (size.width) + "x" + std::to_string (size.height));
  std::vector<int> id_values;
  std::vector<Instance> instances;
  try
  {
    instances = instancesFromIdImage (ids, &id_values);
  }
  catch (const Error& e)
  {
    throw Error (png, e.what ());
  }
  const std::string json_path = (fs::path (png).parent_path () / fs::path (png).stem ()).string () + ".json";
  boost::system::error_code ec;
  if (!fs::exists (json_path, ec))
    return instances;
  nlohmann::json doc;
  try
  {
    doc = io::parseJson (io::readTextFile (json_path), json_path);
    for (const auto& entry : doc.at ("instances"))
    {
      // Ids and class ids are integers, scores probabilities: anything else is refused
      // (a class_id of 1e20 would become INT_MIN, a score of 1e300 outvote every mask).
      const auto& id_value = entry.at ("id");
      if (!id_value.is_number_integer ())
        throw Error (json_path, "instance id " + io::jsonText (id_value) + " is not an integer");
      const long long id = id_value.get<long long> ();
      const auto it = std::find (id_values.begin (), id_values.end (), id);
      if (it == id_values.end ())
        continue;  // described but not visible in the PNG
      Instance& instance = instances[static_cast<std::size_t> (it - id_values.begin ())];
      if (entry.contains ("class_id"))
      {
        const auto& class_id = entry.at ("class_id");
        if (!class_id.is_number_integer () || class_id.get<long long> () < -1 || class_id.get<long long> () > 1000000)
          throw Error (json_path, "class_id " + io::jsonText (class_id) + " of instance " + std::to_string (id) +
                                    " is not an integer in [-1, 1000000]");
        instance.class_id = class_id.get<int> ();
      }
      instance.class_name = entry.value ("class_name", std::string ());
      if (instance.class_name.empty () && instance.class_id >= 0 &&
          static_cast<std::size_t> (instance.class_id) < class_names.size ())
        instance.class_name = class_names[static_cast<std::size_t> (instance.class_id)];
      if (entry.contains ("score"))
      {
        const auto& score = entry.at ("score");
        if (!score.is_number () || !(score.get<double> () >= 0.0 && score.get<double> () <= 1.0))
          throw Error (json_path, "score " + io::jsonText (score) + " of instance " + std::to_string (id) + " is not in [0, 1]");
        instance.score = score.get<float> ();
      }
    }
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (json_path, std::string ("not a mask description (") + e.what () + ")");
  }
  return instances;
}

bool
MaskFolderSegmenter::segment (const RGBDFrame& frame, std::vector<Instance>& instances)
{
  instances.clear ();
  const std::string path = maskPathFor (frame);
  if (path.empty ())
    return false;
  instances = readMasks (path, frame.depth.empty () ? frame.color.size () : frame.depth.size ());
  return true;
}
}  // namespace recognition
}  // namespace cuefusion
