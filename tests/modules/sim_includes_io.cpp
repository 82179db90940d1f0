// Compiled against module sim's include root by the Modules.AnUpwardIncludeFailsTheBuild test:
// sim sits below io (DESIGN.md), so this include must not be found. Never part of a build.
#include "lamina/io/scene.h"
