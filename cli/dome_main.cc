#include "cli/app.h"

int main(int argc, char** argv) { return dome::cli::RunDome(argc, argv); }
