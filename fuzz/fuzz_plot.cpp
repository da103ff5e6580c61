// SPDX-License-Identifier: BSD-3-Clause
// The gnuplot script writer (eval's and batch's plots): text from datasets and options
// (class names, run names, file names) must stay inside its string literals. The input
// is split at 0xff bytes into the texts of a two-series chart; the script written from
// them must have the same commands as the script of a chart with harmless texts, every
// literal closed on its line and free of control characters.
#include "../apps/cuefusion/gnuplot.h"

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

namespace
{
/** The script with the contents of every single-quoted literal taken out: what gnuplot
  * runs, whatever the texts. Aborts on a literal left open at the end of a line or one
  * holding a control character. */
std::string
commands (const std::string& script)
{
  std::string out;
  bool in_literal = false;
  for (std::size_t i = 0; i < script.size (); ++i)
  {
    const char c = script[i];
    if (in_literal)
    {
      if (c == '\'' && i + 1 < script.size () && script[i + 1] == '\'')
        ++i;  // a doubled quote: one quote inside the literal
      else if (c == '\'')
      {
        in_literal = false;
        out += '\'';
      }
      else if (static_cast<unsigned char> (c) < 0x20 || c == 0x7f)
        std::abort ();
      continue;
    }
    if (c == '\'')
      in_literal = true;
    out += c;
  }
  if (in_literal)
    std::abort ();
  return out;
}

cuefusion::cli::PlotSpec
chart (const std::vector<std::string>& text)
{
  cuefusion::cli::PlotSpec spec;
  spec.output_png = "plots/" + text[0] + ".png";
  spec.title = text[1];
  spec.xlabel = text[2];
  spec.ylabel = text[3];
  spec.yrange = "[0:1.05]";
  spec.series.push_back ({"plots/" + text[4] + ".dat", 1, 2, text[5], "lines", 0});
  spec.series.push_back ({"plots/" + text[6] + ".dat", 1, 3, text[7], "points pt 7 ps 1.6", 4});
  return spec;
}
}  // namespace

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  std::vector<std::string> text (8);
  std::size_t k = 0;
  for (std::size_t i = 0; i < size; ++i)
  {
    if (data[i] == 0xff)
    {
      if (++k == text.size ())
        break;
    }
    else
      text[k] += static_cast<char> (data[i]);
  }
  for (std::string& t : text)  // a name of a file, never a folder
    if (t.find ('/') != std::string::npos || t.empty () || t == "." || t == "..")
      t = "x" + std::to_string (t.size ());
  const std::vector<std::string> harmless {"a", "b", "c", "d", "e", "f", "g", "h"};
  const std::string script = cuefusion::cli::gnuplotScript (chart (text), text[0] + ".png");
  if (commands (script) != commands (cuefusion::cli::gnuplotScript (chart (harmless), "a.png")))
    std::abort ();
  return 0;
}
