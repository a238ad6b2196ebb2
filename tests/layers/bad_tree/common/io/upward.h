// An io header reaching up and into the wire (check_includes.py must refuse both).
#include "rig.pb.h"
#include "stereo/multi_baseline.h"
