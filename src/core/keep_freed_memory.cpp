#include "lamina/core/keep_freed_memory.h"

#include <malloc.h>

namespace lamina {

void keep_freed_memory() {
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

}  // namespace lamina
