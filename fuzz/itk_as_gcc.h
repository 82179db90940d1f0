// Debian's ITK 5.2 generated itk_compiler_detection.h for GCC alone: any other compiler stops at
// "#error Unsupported compiler". The fuzz build must use clang (libFuzzer), which compiles ITK's
// headers as GCC does. This prelude (-include, fuzz/CMakeLists.txt) includes that header first,
// with clang passing for GCC 12 just while it is read; its include guard then makes every later
// include of it a no-op. LAMINA_ITK_DETECTION is its full path.
#pragma push_macro("__clang__")
#pragma push_macro("__GNUC__")
#pragma push_macro("__GNUC_MINOR__")
#undef __clang__
#undef __GNUC__
#undef __GNUC_MINOR__
#define __GNUC__ 12
#define __GNUC_MINOR__ 2
#include LAMINA_ITK_DETECTION
#pragma pop_macro("__GNUC_MINOR__")
#pragma pop_macro("__GNUC__")
#pragma pop_macro("__clang__")
