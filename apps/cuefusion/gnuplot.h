// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <string>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** One line of a gnuplot chart: columns \a x_column / \a y_column of \a data_file. */
struct PlotSeries
{
  std::string data_file;   ///< whitespace-separated columns, '#' comments
  int x_column = 1;
  int y_column = 2;
  std::string title;
  std::string style = "lines";   ///< gnuplot "with" clause
  int xtic_column = 0;            ///< > 0: label the x axis with this column's text
};

struct PlotSpec
{
  std::string output_png;
  std::string title, xlabel, ylabel;
  std::string yrange;        ///< e.g. "[0:1]", empty = automatic
  bool equal_axes = false;   ///< same scale on x and y (maps, trajectories)
  std::vector<PlotSeries> series;
};

/** \a text as a gnuplot single-quoted string literal that nothing can leave: quotes
  * doubled, control characters (a newline would end the command) shown as spaces. The
  * one way text from files and options enters a gnuplot script. */
std::string
gnuplotString (const std::string& text);

/** The gnuplot script that draws \a spec into \a output_name (relative to the script's
  * folder). Every text of the spec goes through gnuplotString. */
std::string
gnuplotScript (const PlotSpec& spec, const std::string& output_name);

/** gnuplot on PATH, or "" when it is not installed. */
std::string
findGnuplot ();

/** Writes \a spec as a gnuplot script next to its PNG (same name, .gp) — kept, so a user
  * can restyle the chart — and runs \a gnuplot on it. The PNG is rendered to a temporary
  * name and renamed, never left half-written. Throws cuefusion::Error with gnuplot's
  * message when it fails.
  *
  * gnuplot (Debian gnuplot-nox) draws the charts: a maintained, scriptable plotter with a
  * headless cairo PNG terminal, needing no Python runtime, no display and no new C++
  * library in the binary; the .gp files it leaves behind are plain text a user can edit.
  */
void
renderPlot (const std::string& gnuplot, const PlotSpec& spec);
}  // namespace cli
}  // namespace cuefusion
