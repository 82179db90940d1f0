// Compiled against module sim's include root by the Modules.ADownwardIncludeBuilds test: model
// sits below sim, so this builds (and shows that the upward probe fails for its include only).
#include "lamina/model/model.h"
#include "sim/solver.h"
