// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/io/settings_json.h>

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace cuefusion
{
namespace io
{
namespace
{
std::string
typeName (const nlohmann::json& j)
{
  return j.is_number () ? "a number" : std::string ("a ") + j.type_name ();
}

nlohmann::json
vectorJson (const Eigen::Vector3d& v)
{
  return {v.x (), v.y (), v.z ()};
}
}  // namespace

void
SettingsWriter::operator() (const char* name, float value)
{
  char text[64];
  const std::to_chars_result r = std::to_chars (text, text + sizeof (text), value);
  json[name] = std::strtod (std::string (text, r.ptr).c_str (), nullptr);
}

void
SettingsWriter::operator() (const char* name, const std::optional<Eigen::AlignedBox3d>& value)
{
  json[name] = value ? nlohmann::json{{"min", vectorJson (value->min ())}, {"max", vectorJson (value->max ())}} : nlohmann::json ();
}

SettingsReader::SettingsReader (const nlohmann::json& json, std::string path) : json_ (json), path_ (std::move (path))
{
  if (!json_.is_object ())
    throw ParameterError (path_, "must be a JSON object of settings, not " + typeName (json_));
}

const nlohmann::json*
SettingsReader::take (const char* name)
{
  const auto it = json_.find (name);
  if (it == json_.end ())
    return nullptr;
  taken_.insert (name);
  return &*it;
}

std::string
SettingsReader::path (const char* name) const
{
  return path_.empty () ? std::string (name) : path_ + "." + name;
}

void
SettingsReader::fail (const char* name, const std::string& what) const
{
  throw ParameterError (path (name), what);
}

void
SettingsReader::finish () const
{
  for (auto it = json_.begin (); it != json_.end (); ++it)
    if (!taken_.count (it.key ()))
      throw ParameterError (path (it.key ().c_str ()), "is not a setting here (names are the library's Config fields; "
                                                       "`--print-config` lists them)");
}

template <class T>
void
SettingsReader::typed (const char* name, T& value, bool (nlohmann::json::*is) () const noexcept, const char* expected)
{
  if (const nlohmann::json* j = take (name))
  {
    if (!(j->*is) ())
      fail (name, std::string ("must be ") + expected + ", not " + typeName (*j));
    value = j->get<T> ();
  }
}

void
SettingsReader::operator() (const char* name, bool& value)
{
  typed (name, value, &nlohmann::json::is_boolean, "true or false");
}

template <class Integer>
void
SettingsReader::integer (const char* name, Integer& value)
{
  if (const nlohmann::json* j = take (name))
  {
    // Whole numbers only: 2.5 or "3" for a count is a mistake, not something to round.
    const bool whole = j->is_number_integer () || (j->is_number_float () && std::isfinite (j->get<double> ()) &&
                                                   j->get<double> () == std::floor (j->get<double> ()));
    if (!whole)
      fail (name, "must be a whole number, not " + (j->is_number () ? j->dump () : typeName (*j)));
    const long double v = j->is_number_unsigned () ? static_cast<long double> (j->get<std::uint64_t> ())
                                                    : static_cast<long double> (j->is_number_integer () ? j->get<std::int64_t> () : j->get<double> ());
    if (v < static_cast<long double> (std::numeric_limits<Integer>::min ()) ||
        v > static_cast<long double> (std::numeric_limits<Integer>::max ()))
      fail (name, "must lie in [" + std::to_string (std::numeric_limits<Integer>::min ()) + ", " +
                      std::to_string (std::numeric_limits<Integer>::max ()) + "], not " + j->dump ());
    value = static_cast<Integer> (v);
  }
}

void SettingsReader::operator() (const char* name, int& value) { integer (name, value); }
void SettingsReader::operator() (const char* name, unsigned& value) { integer (name, value); }
void SettingsReader::operator() (const char* name, unsigned long& value) { integer (name, value); }

void
SettingsReader::operator() (const char* name, double& value)
{
  typed (name, value, &nlohmann::json::is_number, "a number");
}

void
SettingsReader::operator() (const char* name, float& value)
{
  double v = value;
  (*this) (name, v);
  if (std::abs (v) > std::numeric_limits<float>::max ())
    fail (name, "is too large for this setting (a float)");
  value = static_cast<float> (v);
}

void
SettingsReader::operator() (const char* name, std::string& value)
{
  typed (name, value, &nlohmann::json::is_string, "a string");
}

void
SettingsReader::operator() (const char* name, std::vector<int>& value)
{
  const nlohmann::json* j = take (name);
  if (!j)
    return;
  if (!j->is_array ())
    fail (name, "must be an array of whole numbers, not " + typeName (*j));
  std::vector<int> read (j->size ());
  for (std::size_t i = 0; i < j->size (); ++i)
  {
    const nlohmann::json element = {{"v", (*j)[i]}};
    SettingsReader one (element, path (name) + "[" + std::to_string (i) + "]");
    one.integer ("v", read[i]);
  }
  value = std::move (read);
}

void
SettingsReader::operator() (const char* name, cv::Size& value)
{
  std::vector<int> wh{value.width, value.height};
  (*this) (name, wh);
  if (wh.size () != 2)
    fail (name, "must be [width, height]");
  value = cv::Size (wh[0], wh[1]);
}

void
SettingsReader::operator() (const char* name, std::optional<Eigen::AlignedBox3d>& value)
{
  const nlohmann::json* j = take (name);
  if (!j)
    return;
  if (j->is_null ())
  {
    value.reset ();
    return;
  }
  const auto corner = [&] (const char* which) {
    const auto it = j->is_object () ? j->find (which) : j->end ();
    if (it == j->end () || !it->is_array () || it->size () != 3 || !(*it)[0].is_number () || !(*it)[1].is_number () ||
        !(*it)[2].is_number ())
      fail (name, "must be null or {\"min\": [x, y, z], \"max\": [x, y, z]}");
    return Eigen::Vector3d ((*it)[0].get<double> (), (*it)[1].get<double> (), (*it)[2].get<double> ());
  };
  if (!j->is_object () || j->size () != 2)
    fail (name, "must be null or {\"min\": [x, y, z], \"max\": [x, y, z]}");
  value = Eigen::AlignedBox3d (corner ("min"), corner ("max"));
}

nlohmann::json
readSettingsFile (const std::string& path)
{
  nlohmann::json j = readJsonFile (path);
  if (!j.is_object ())
    throw Error (path, "not a settings file: a JSON object was expected");
  // A run's outputs.json: the settings it ran with.
  if (j.contains ("config") && j.contains ("command_line"))
    return j["config"];
  return j;
}
}  // namespace io
}  // namespace cuefusion
