#pragma once

#include <stdexcept>
#include <string>

namespace cuefusion
{
/** \brief Error raised for bad input (files, folders, parameters).
  *
  * The message is one line and names the offending file or option first, so a
  * command-line front end can print it as is.
  */
class Error : public std::runtime_error
{
public:
  explicit Error (const std::string& what) : std::runtime_error (what) {}
  /** \brief "<where>: <what>", e.g. Error ("depth/3.png", "cannot decode image"). */
  Error (const std::string& where, const std::string& what) : std::runtime_error (where + ": " + what) {}
};
}  // namespace cuefusion

namespace cuefusion
{
/** \brief A parameter outside its valid range, named as its config field
  * ("Class::field"; older code still names the command-line option): the command line
  * translates field names into its options.
  */
class ParameterError : public Error
{
public:
  ParameterError (const std::string& parameter, const std::string& what)
    : Error (parameter, what), parameter_ (parameter), reason_ (what)
  {
  }
  const std::string& parameter () const { return parameter_; }
  const std::string& reason () const { return reason_; }

private:
  std::string parameter_, reason_;
};
}  // namespace cuefusion
