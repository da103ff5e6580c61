#include "cli.h"

#include <iostream>

namespace cuefusion
{
namespace cli
{
bool
parseCommandLine (const std::string& command, const std::string& synopsis, const std::vector<std::string>& args,
                  po::options_description& options, const po::positional_options_description& positional,
                  po::variables_map& vm)
{
  options.add_options () ("help,h", "show this help");
  try
  {
    po::store (po::command_line_parser (args).options (options).positional (positional).run (), vm);
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
}  // namespace cli
}  // namespace cuefusion
