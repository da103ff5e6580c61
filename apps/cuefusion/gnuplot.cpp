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
namespace
{
/** gnuplot single-quoted string: only ' needs escaping (doubled). */
std::string
quoted (const std::string& s)
{
  std::string out = "'";
  for (const char c : s)
    out += c == '\'' ? std::string ("''") : std::string (1, c);
  return out + "'";
}
}  // namespace

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
  std::ostringstream gp;
  gp << "# " << spec.title << " — written by cuefusion; run `gnuplot " << script.filename ().string ()
     << "` here to redraw\n"
     << "set terminal pngcairo size 1000,640 enhanced font 'sans,11'\n"
     << "set output " << quoted (png.filename ().string ()) << "\n"
     << "set title " << quoted (spec.title) << " noenhanced\n"
     << "set xlabel " << quoted (spec.xlabel) << "\nset ylabel " << quoted (spec.ylabel) << "\n"
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
    gp << (i ? ", \\\n     " : "") << quoted (fs::path (s.data_file).filename ().string ()) << " using " << s.x_column << ":"
       << s.y_column << (s.xtic_column > 0 ? ":xtic(" + std::to_string (s.xtic_column) + ")" : std::string ()) << " with " << s.style << " lw 2 title " << quoted (s.title);
  }
  gp << "\n";
  io::writeTextAtomic (script.string (), gp.str ());

  // Run in the plot's folder (the script names files relative to it), output to the
  // temporary name, so a failure leaves no broken PNG.
  std::string text = gp.str ();
  const std::string target_line = "set output " + quoted (png.filename ().string ());
  text.replace (text.find (target_line), target_line.size (), "set output " + quoted (temporary.filename ().string ()));
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
