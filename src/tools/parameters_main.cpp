// Prints doc/PARAMETERS.md from the parameter table:
//   scripts/env.sh rosrun flexcloud flexcloud_parameters > doc/PARAMETERS.md
#include <cstring>
#include <iostream>

#include "flexcloud/ros/node_params.h"

int main(int argc, char** argv) {
  if (argc > 1) {
    const bool help = std::strcmp(argv[1], "-h") == 0 || std::strcmp(argv[1], "--help") == 0;
    (help ? std::cout : std::cerr) << "usage: flexcloud_parameters   (prints doc/PARAMETERS.md "
                                      "from the parameter table)\n";
    return help ? 0 : 2;
  }
  std::cout << flexcloud::parametersMarkdown();
  return 0;
}
