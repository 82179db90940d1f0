/* Force-included into every C++ compile with GCC 12 on x86 (CMakeLists.txt). GCC 12's own
   AVX-512 header initialises `_mm512_undefined_pd()` and its kin from themselves
   (`__m512d __Y = __Y;`), and every Eigen reduction that inlines one reports
   -Wmaybe-uninitialized (or -Wuninitialized) from that header: 963 of a clean build's 989 warnings
   on an AVX-512 machine (GCC bug 105593, fixed in GCC 13). Including the intrinsics here, first,
   with the warning off, silences it at its source only: the header's lines are then read under this
   pragma, while the project's own code keeps -Wmaybe-uninitialized (checked: a maybe-uninitialized
   local in a source still warns). */
#if defined(__cplusplus) && defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12 && \
    (defined(__x86_64__) || defined(__i386__))
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif
