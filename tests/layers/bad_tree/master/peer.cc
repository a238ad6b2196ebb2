// The master reaching into its peer (check_includes.py must refuse it).
#include "worker/worker.h"
