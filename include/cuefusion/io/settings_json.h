// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief Settings files: a library Config as JSON, one member per field under the
  * field's own name, nested Configs as nested objects (docs/commands.md "Settings
  * files").
  *
  * A Config lists its fields once, for both directions, in a function found by
  * argument-dependent lookup beside it:
  * \code
  *   template <class Visitor> void fields (Visitor& v, TSDFVolumeConfig& c)
  *   { v ("voxel_size", c.voxel_size); v ("max_depth", c.max_depth); ... }
  * \endcode
  * SettingsWriter visits a copy and collects the values; SettingsReader visits the
  * Config to change and sets only the members the JSON has, so a file may give a few
  * fields and leave the rest as they were. Reading is strict: a member that names no
  * field, or a value of the wrong type or out of the field's range, is a ParameterError
  * naming the member's path ("pipeline.reconstruction.volume.voxel_sise"); ranges beyond
  * the type's are the Configs' own validate(). */
class SettingsWriter
{
public:
  nlohmann::json json = nlohmann::json::object ();

  void operator() (const char* name, bool value) { json[name] = value; }
  void operator() (const char* name, int value) { json[name] = value; }
  void operator() (const char* name, unsigned value) { json[name] = value; }
  void operator() (const char* name, unsigned long value) { json[name] = value; }
  /// as the shortest decimal that reads back as the same float (0.3, not 0.30000001192092896)
  void operator() (const char* name, float value);
  void operator() (const char* name, double value) { json[name] = value; }
  void operator() (const char* name, const std::string& value) { json[name] = value; }
  void operator() (const char* name, const std::vector<int>& value) { json[name] = value; }
  void operator() (const char* name, const cv::Size& value) { json[name] = {value.width, value.height}; }
  /// null, or {"min": [x, y, z], "max": [x, y, z]}
  void operator() (const char* name, const std::optional<Eigen::AlignedBox3d>& value);

  /** A nested Config. */
  template <class Config>
  auto
  operator() (const char* name, Config& value) -> decltype (fields (std::declval<SettingsWriter&> (), value), void ())
  {
    SettingsWriter nested;
    fields (nested, value);
    json[name] = std::move (nested.json);
  }

  /** An enumeration, written by its name in \a names. */
  template <class Enum>
  void
  choice (const char* name, Enum value, std::initializer_list<std::pair<const char*, Enum>> names)
  {
    for (const auto& [text, e] : names)
      if (e == value)
        json[name] = text;
  }
};

class SettingsReader
{
public:
  /** Reads from \a json, an object (ParameterError naming \a path otherwise); \a path is
    * the object's place in the file, for messages ("pipeline"). */
  SettingsReader (const nlohmann::json& json, std::string path);

  void operator() (const char* name, bool& value);
  void operator() (const char* name, int& value);
  void operator() (const char* name, unsigned& value);
  void operator() (const char* name, unsigned long& value);
  void operator() (const char* name, float& value);
  void operator() (const char* name, double& value);
  void operator() (const char* name, std::string& value);
  void operator() (const char* name, std::vector<int>& value);
  void operator() (const char* name, cv::Size& value);
  void operator() (const char* name, std::optional<Eigen::AlignedBox3d>& value);

  template <class Config>
  auto
  operator() (const char* name, Config& value) -> decltype (fields (std::declval<SettingsReader&> (), value), void ())
  {
    if (const nlohmann::json* member = take (name))
    {
      SettingsReader nested (*member, path (name));
      fields (nested, value);
      nested.finish ();
    }
  }

  template <class Enum>
  void
  choice (const char* name, Enum& value, std::initializer_list<std::pair<const char*, Enum>> names)
  {
    const nlohmann::json* member = take (name);
    if (!member)
      return;
    std::string known;
    for (const auto& [text, e] : names)
    {
      if (member->is_string () && member->get_ref<const std::string&> () == text)
      {
        value = e;
        return;
      }
      known += (known.empty () ? "" : ", ") + std::string (text);
    }
    fail (name, "must be one of " + known);
  }

  /** Throws ParameterError for the first member no field took. Call after fields(). */
  void finish () const;

private:
  const nlohmann::json* take (const char* name);
  std::string path (const char* name) const;
  [[noreturn]] void fail (const char* name, const std::string& what) const;
  template <class Integer>
  void integer (const char* name, Integer& value);
  /** A member of one JSON type (\a is), read as T; \a expected names the type in errors. */
  template <class T>
  void typed (const char* name, T& value, bool (nlohmann::json::*is) () const noexcept, const char* expected);

  const nlohmann::json& json_;
  std::string path_;
  std::set<std::string> taken_;
};

/** \brief \a config as JSON (every field). */
template <class Config>
nlohmann::json
settingsJson (Config config)
{
  SettingsWriter writer;
  fields (writer, config);
  return std::move (writer.json);
}

/** \brief Sets the fields of \a config that \a json gives; \a path names \a json in
  * messages. Strict as SettingsReader. */
template <class Config>
void
readSettings (const nlohmann::json& json, Config& config, const std::string& path)
{
  SettingsReader reader (json, path);
  fields (reader, config);
  reader.finish ();
}

/** \brief The settings in a file: a settings file (JSON object), or a run's outputs.json,
  * whose "config" member is the settings the run used. cuefusion::Error naming the file
  * when it cannot be read, is not JSON or is not an object. */
nlohmann::json
readSettingsFile (const std::string& path);
}  // namespace io
}  // namespace cuefusion
