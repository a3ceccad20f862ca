// A model/ file that includes a step/ header: scripts/check-rooms.sh must refuse it (its own test).
#include "step/world_impl.hpp"
