// SPDX-License-Identifier: BSD-3-Clause
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

namespace cuefusion
{
/** \brief Names the file an operation reads or writes, for errors raised by code that
  * cannot name it (PCL's readers and writers, the standard library, nlohmann::json, an
  * allocation that fails).
  *
  * Put one at the top of a function that works on a file. When an exception leaves its
  * scope, the innermost such file is recorded (per thread) and describeException()
  * puts it in front of the message; a new outermost FileContext forgets an older record.
  */
class FileContext
{
public:
  explicit FileContext (std::string path);
  ~FileContext ();
  FileContext (const FileContext&) = delete;
  FileContext& operator= (const FileContext&) = delete;

  /** The file of the last exception that left a FileContext in this thread, or "". */
  static const std::string&
  failingFile ();

private:
  std::string path_;
  int exceptions_;
};

/** \brief One line for any exception: cuefusion::Error as it is (it names its file or
  * option), others prefixed by FileContext::failingFile() when there is one; out of
  * memory says so. Line breaks in third-party messages become "; ". */
std::string
describeException (const std::exception& e);
}  // namespace cuefusion
