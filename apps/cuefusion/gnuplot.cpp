// SPDX-License-Identifier: BSD-3-Clause
#include "gnuplot.h"
#include "process.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <boost/filesystem.hpp>

#include <algorithm>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
std::string
gnuplotString (const std::string& text)
{
  // In a single-quoted gnuplot string nothing is special but the quote itself (doubled)
  // and the end of the line, which ends the string and the command: the next line would
  // run as gnuplot, and gnuplot's `system` runs shell commands. Every control character
  // (newline, carriage return, form feed, ...) and DEL is shown as a space. Backquotes
  // are not substituted inside single quotes.
  std::string out = "'";
  for (const char c : text)
  {
    const auto u = static_cast<unsigned char> (c);
    if (u < 0x20 || u == 0x7f)
      out += ' ';
    else if (c == '\'')
      out += "''";
    else
      out += c;
  }
  return out + "'";
}

std::string
gnuplotScript (const PlotSpec& spec, const std::string& output_name)
{
  // Only gnuplotString carries text from the spec into the script; the rest is the
  // project's own (numbers, the styles and ranges of the charts cuefusion draws).
  std::ostringstream gp;
  gp << "# written by cuefusion; to redraw, run gnuplot on this file in its folder\n"
     << "set terminal pngcairo size 1000,640 enhanced font 'sans,11'\n"
     << "set output " << gnuplotString (output_name) << "\n"
     << "set title " << gnuplotString (spec.title) << " noenhanced\n"
     << "set xlabel " << gnuplotString (spec.xlabel) << " noenhanced\nset ylabel " << gnuplotString (spec.ylabel) << " noenhanced\n"
     << "set grid\nset key outside right top noenhanced\n";
  if (!spec.yrange.empty ())
    gp << "set yrange " << spec.yrange << "\n";
  if (spec.equal_axes)
    gp << "set size ratio -1\n";
  if (std::any_of (spec.series.begin (), spec.series.end (), [] (const PlotSeries& s) { return s.xtic_column > 0; }))
    gp << "set xtics rotate by 30 right noenhanced\nset offsets 0.5, 0.5, 0, 0\n";  // names on the axis
  gp << "plot ";
  for (std::size_t i = 0; i < spec.series.size (); ++i)
  {
    const PlotSeries& s = spec.series[i];
    gp << (i ? ", \\\n     " : "") << gnuplotString (fs::path (s.data_file).filename ().string ()) << " using " << s.x_column << ":"
       << s.y_column << (s.xtic_column > 0 ? ":xtic(" + std::to_string (s.xtic_column) + ")" : std::string ()) << " with " << s.style
       << " lw 2 title " << gnuplotString (s.title);
  }
  gp << "\n";
  return gp.str ();
}

std::string
findGnuplot ()
{
  return findOnPath ("gnuplot");
}

void
renderPlot (const std::string& gnuplot, const PlotSpec& spec)
{
  const fs::path png (spec.output_png);
  const fs::path temporary = png.parent_path () / fs::unique_path ("." + png.stem ().string () + ".tmp-%%%%%%.png");
  const fs::path script = fs::path (png).replace_extension (".gp");
  const fs::path log = png.parent_path () / fs::unique_path ("." + png.stem ().string () + ".log-%%%%%%");
  io::writeTextAtomic (script.string (), gnuplotScript (spec, png.filename ().string ()));

  // Run in the plot's folder (the script names files relative to it), output to the
  // temporary name, so a failure leaves no broken PNG.
  const std::string text = gnuplotScript (spec, temporary.filename ().string ());
  const fs::path run_script = png.parent_path () / fs::unique_path (".plot-%%%%%%.gp");
  io::writeTextAtomic (run_script.string (), text);

  const std::string directory = png.parent_path ().empty () ? "." : png.parent_path ().string ();
  const ProcessResult done = runProcess ({gnuplot, run_script.filename ().string ()}, {"/dev/null"}, {log.string ()}, directory);
  boost::system::error_code ec;
  fs::remove (run_script, ec);
  std::string message;
  if (fs::exists (log))
  {
    message = io::readTextFile (log.string ());
    fs::remove (log, ec);
  }
  if (!done.ok () || !fs::exists (temporary))
  {
    fs::remove (temporary, ec);
    const auto end = message.find ('\n', message.find_first_not_of ("\n "));
    throw Error (script.string (), "gnuplot failed" + (message.empty () ? std::string () : ": " + message.substr (0, end)));
  }
  fs::rename (temporary, png, ec);
  if (ec)
    throw Error (png.string (), "cannot move the plot into place: " + ec.message ());
}
}  // namespace cli
}  // namespace cuefusion
