// Prints doc/PARAMETERS.md, or with --yaml config/georeference.yaml, from the parameter table:
//   scripts/env.sh rosrun flexcloud flexcloud_parameters > doc/PARAMETERS.md
//   scripts/env.sh rosrun flexcloud flexcloud_parameters --yaml > config/georeference.yaml
#include <cstring>
#include <iostream>

#include "flexcloud/ros/node_params.h"

int main(int argc, char** argv) {
  const bool yaml = argc == 2 && std::strcmp(argv[1], "--yaml") == 0;
  if (argc > 2 || (argc == 2 && !yaml)) {
    const bool help = std::strcmp(argv[1], "-h") == 0 || std::strcmp(argv[1], "--help") == 0;
    (help ? std::cout : std::cerr)
        << "usage: flexcloud_parameters [--yaml]   (prints doc/PARAMETERS.md, or with --yaml "
           "config/georeference.yaml, from the parameter table)\n";
    return help ? 0 : 2;
  }
  std::cout << (yaml ? flexcloud::parametersYaml() : flexcloud::parametersMarkdown());
  return 0;
}
