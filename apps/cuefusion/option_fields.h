// SPDX-License-Identifier: BSD-3-Clause
// The command line's options bound to the library's Config fields, declared once
// (option_fields.cpp) and read both where the commands define their options and where
// main.cpp turns the library's ParameterError, which names fields, into option names.
#pragma once

#include <string>

namespace cuefusion
{
namespace cli
{
/** \brief The option (without dashes) bound to \a field ("TSDFVolumeConfig::voxel_size"
  * → "voxel"), for a boost::program_options definition; std::logic_error when none is
  * (a defect of the command, found by its --help). */
const char*
boundOption (const char* field);

/** \brief "--option" for a ParameterError's parameter, "" when no option is bound to it. */
std::string
optionOfParameter (const std::string& parameter);
}  // namespace cli
}  // namespace cuefusion
