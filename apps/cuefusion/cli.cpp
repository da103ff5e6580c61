// SPDX-License-Identifier: BSD-3-Clause
#include "cli.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/settings_json.h>

#include <boost/filesystem.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <iostream>

namespace cuefusion
{
namespace cli
{
namespace
{
/** Boost reads "-5" into an unsigned option as 2^64 - 5 (lexical_cast wraps): every
  * option stored as an unsigned count is refused here when its text is negative. */
void
refuseNegativeCounts (const po::parsed_options& given, const po::variables_map& vm)
{
  for (const po::option& o : given.options)
  {
    if (o.string_key.empty () || !vm.count (o.string_key))
      continue;
    const boost::any& value = vm[o.string_key].value ();
    const bool is_unsigned = value.type () == typeid (unsigned) || value.type () == typeid (unsigned long) ||
                             value.type () == typeid (unsigned long long) || value.type () == typeid (unsigned short) ||
                             value.type () == typeid (unsigned char);
    if (!is_unsigned)
      continue;
    for (const std::string& text : o.value)
    {
      const auto first = text.find_first_not_of (" \t");
      if (first != std::string::npos && text[first] == '-')
        throw ParameterError ("--" + o.string_key, "must not be negative (got " + text + ")");
    }
  }
}
}  // namespace

bool
parseCommandLine (const std::string& command, const std::string& synopsis, const std::vector<std::string>& args,
                  po::options_description& options, const po::positional_options_description& positional,
                  po::variables_map& vm, std::vector<po::option>* parsed)
{
  options.add_options () ("help,h", "show this help");
  try
  {
    const po::parsed_options given_options = po::command_line_parser (args).options (options).positional (positional).run ();
    po::store (given_options, vm);
    refuseNegativeCounts (given_options, vm);
    if (parsed)
      *parsed = given_options.options;
    if (vm.count ("help"))
    {
      std::cout << "usage: cuefusion " << command << " " << synopsis << "\n\n" << options << "\n";
      return false;
    }
    po::notify (vm);
  }
  catch (const po::error& e)
  {
    throw UsageError (e.what ());
  }
  return true;
}
std::string
configArgument (const std::vector<std::string>& args)
{
  std::string path;
  for (std::size_t i = 0; i < args.size (); ++i)
  {
    if (args[i] == "--")
      break;
    if (args[i] == "--config" && i + 1 < args.size ())
      path = args[i + 1];
    else if (args[i].rfind ("--config=", 0) == 0)
      path = args[i].substr (9);
  }
  return path;
}

void
readConfigParts (const std::string& command, const std::vector<std::string>& args,
                 const std::vector<std::pair<std::string, std::function<void (const nlohmann::json&)>>>& parts)
{
  const std::string path = configArgument (args);
  if (path.empty ())
    return;
  const nlohmann::json file = io::readSettingsFile (path);
  try
  {
    std::string names;
    for (std::size_t i = 0; i < parts.size (); ++i)
      names += (i == 0 ? "" : i + 1 == parts.size () ? " and " : ", ") + ("\"" + parts[i].first + "\"");
    for (auto it = file.begin (); it != file.end (); ++it)
      if (std::none_of (parts.begin (), parts.end (), [&] (const auto& part) { return part.first == it.key (); }))
        throw ParameterError (it.key (), "is not a part of " + command + "'s settings (they are " + names + ")");
    for (const auto& [name, read] : parts)
      if (file.contains (name))
        read (file[name]);
  }
  catch (const ParameterError& e)
  {
    throw Error (path, e.what ());  // the file's fault, not an option's
  }
}

nlohmann::json
numberOrNull (double v)
{
  return std::isfinite (v) ? nlohmann::json (v) : nlohmann::json (nullptr);
}

std::string
csvNumber (double v)
{
  if (!std::isfinite (v))
    return "";
  std::ostringstream s;
  s << std::setprecision (6) << v;
  return s.str ();
}

std::string
csvText (const std::string& s)
{
  if (s.find_first_of (",\"\n\r") == std::string::npos)
    return s;
  std::string out = "\"";
  for (const char c : s)
    out += c == '"' ? std::string ("\"\"") : std::string (1, c);
  return out + "\"";
}

nlohmann::json
apJson (const evaluation::APScores& s)
{
  return {{"ap", numberOrNull (s.ap)}, {"ap50", numberOrNull (s.ap50)}, {"ap25", numberOrNull (s.ap25)}};
}

std::vector<std::string>
listInputs (const std::string& path, const std::vector<std::string>& extensions)
{
  namespace fs = boost::filesystem;
  boost::system::error_code ec;
  if (!fs::exists (path, ec))
    throw Error (path, "no such file or folder");
  if (!fs::is_directory (path, ec))
    return {path};
  std::vector<std::string> files;
  for (fs::directory_iterator it (path, ec), end; !ec && it != end; it.increment (ec))
  {
    std::string extension = it->path ().extension ().string ();
    std::transform (extension.begin (), extension.end (), extension.begin (), ::tolower);
    if (fs::is_regular_file (it->path (), ec) &&
        std::find (extensions.begin (), extensions.end (), extension) != extensions.end ())
      files.push_back (it->path ().string ());
  }
  if (ec)
    throw Error (path, "cannot list folder: " + ec.message ());
  std::sort (files.begin (), files.end ());
  return files;
}
void
refuseOutputsOverInputs (const std::vector<std::pair<std::string, std::string>>& outputs,
                         const std::vector<std::pair<std::string, std::string>>& inputs)
{
  namespace fs = boost::filesystem;
  const auto resolved = [] (const std::string& path) {
    boost::system::error_code ec;
    const fs::path p = fs::weakly_canonical (fs::absolute (path), ec);
    return ec ? fs::absolute (path).lexically_normal () : p;
  };
  for (const auto& [out_option, out_path] : outputs)
  {
    if (out_path.empty ())
      continue;
    const fs::path out = resolved (out_path);
    for (const auto& [in_option, in_path] : inputs)
      if (!in_path.empty () && resolved (in_path) == out)
        throw UsageError (out_option + ": " + out_path + " is the input of " + in_option + "; cuefusion never writes over its inputs");
  }
}
}  // namespace cli
}  // namespace cuefusion
