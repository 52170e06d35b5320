// edgefusion: the on-robot program and the command line. See cli.h for the commands.
#include "cli.h"

int main(int argc, char** argv) { return ef::app::run_cli(argc, argv); }
