// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>

#include <exception>
#include <new>

namespace cuefusion
{
namespace
{
thread_local std::string g_failing_file;
thread_local int g_depth = 0;
}  // namespace

FileContext::FileContext (std::string path) : path_ (std::move (path)), exceptions_ (std::uncaught_exceptions ())
{
  if (g_depth++ == 0)
    g_failing_file.clear ();
}

FileContext::~FileContext ()
{
  --g_depth;
  // Unwinding an exception thrown inside: the innermost file is recorded first.
  if (std::uncaught_exceptions () > exceptions_ && g_failing_file.empty ())
    g_failing_file = path_;
}

const std::string&
FileContext::failingFile ()
{
  return g_failing_file;
}

std::string
describeException (const std::exception& e)
{
  std::string what;
  if (dynamic_cast<const std::bad_alloc*> (&e))
    what = "out of memory (the input asks for more than this machine has)";
  else
    what = e.what ();
  std::string line;  // each run of line breaks becomes "; "
  for (const char c : what)
    if (c != '\n' && c != '\r')
      line += c;
    else if (!line.empty () && line.back () != ' ')
      line += "; ";
  while (!line.empty () && (line.back () == ' ' || line.back () == ';'))
    line.pop_back ();
  what = line;
  if (dynamic_cast<const Error*> (&e) || FileContext::failingFile ().empty ())
    return what;
  return FileContext::failingFile () + ": " + what;
}
}  // namespace cuefusion
