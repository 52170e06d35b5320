#include "cli.h"

#include <cstdio>

namespace ef::app {

int run_cli(int argc, char** argv) {
  std::fprintf(stderr, "edgefusion: not yet implemented\n");
  return 2;
}

}  // namespace ef::app
