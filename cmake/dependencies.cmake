# Every third-party dependency, found once. Names and gotchas: the team's STACK.md (docs/architecture.md
# says where this build departs from it).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(nanoflann REQUIRED)
find_package(meshoptimizer REQUIRED)
find_package(ZLIB REQUIRED)

# ITK: only the modules we use. We register the IO factories ourselves (src/io/itk_image_io.cpp)
# instead of include(${ITK_USE_FILE}), so ITK's include paths and its bundled Eigen 3.3 stay
# confined to the few translation units that need them.
find_package(ITK 5.2 REQUIRED COMPONENTS
  ITKCommon ITKIOImageBase ITKIONIFTI ITKIONRRD ITKIOMeta ITKIOGDCM ITKGDCM
  ITKDistanceMap ITKConnectedComponents ITKLabelMap ITKBinaryMathematicalMorphology
  ITKImageGrid ITKThresholding ITKRegionGrowing)

# lamina_itk_sources(<files>): lets these sources (and only these) see ITK's headers.
# ITK lists /usr/include among its include directories; passing that as -I breaks libstdc++'s
# #include_next <stdlib.h>, so it is filtered out. Under the sanitizers, one UBSan check is off
# in these files: ITK 5.2's own itkConstNeighborhoodIterator.hxx offsets a null buffer pointer
# ("applying non-zero offset to null pointer"), and its templates are instantiated here. UBSan's
# dynamic-type check (vptr) is off there too: ITK's flood fill and distance filters call their
# functors virtually for every voxel, and checking ITK's own objects' types took 14% of a phantom
# build's time under the sanitizers (perf, 2026-11-27); every other check stays on.
set(LAMINA_ITK_INCLUDES ${ITK_INCLUDE_DIRS})
list(REMOVE_ITEM LAMINA_ITK_INCLUDES /usr/include)
function(lamina_itk_sources)
  set_property(SOURCE ${ARGN} APPEND PROPERTY INCLUDE_DIRECTORIES ${LAMINA_ITK_INCLUDES})
  if(LAMINA_SANITIZE OR LAMINA_FUZZ)
    set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS -fno-sanitize=pointer-overflow
                                                                -fno-sanitize=vptr)
  endif()
endfunction()

# OpenVDB 10: Debian's FindOpenVDB wants Boost.Iostreams; the plain library is enough.
find_library(OPENVDB_LIBRARY openvdb REQUIRED)
find_package(TBB REQUIRED)
find_package(Imath REQUIRED)

# CGAL is header-only. Its usage requirements include -frounding-math, which its exact predicates
# need but which stops GCC vectorising any loop with a sqrt (and slowed the simulation's spring
# pass 3x): so only the sources listed with lamina_cgal_sources() get CGAL's compile flags, and
# targets link CGAL with $<LINK_ONLY:CGAL::CGAL>.
# Under ASan + UBSan (preset asan) these sources are compiled uninstrumented, like the Debian-built
# libraries (ITK, OpenVDB, VTK, GMP) every sanitizer build links: they hold CGAL's header-only
# templates and the conversions to and from them, and instrumenting CGAL's Mesh_3 and polygon
# mesh processing took 23% of the sanitizer build's compile time (docs/testing.md).
find_package(CGAL 5.5 REQUIRED)
function(lamina_cgal_sources)
  set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS -frounding-math)
  set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_DEFINITIONS CGAL_USE_GMPXX=1)
  if(LAMINA_SANITIZE)
    set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS -fno-sanitize=all)
  endif()
endfunction()

# TetGen 1.5 (Debian's libtet1.5-dev): no CMake package, so header and library by name. Its one
# user, src/geometry/tetrahedralize_shells.cpp, defines TETLIBRARY before including tetgen.h.
find_path(TETGEN_INCLUDE_DIR tetgen.h REQUIRED)
find_library(TETGEN_LIBRARY tet REQUIRED)

# CHOLMOD (SuiteSparse 5.12, libsuitesparse-dev): no CMake package either. Its supernodal
# Cholesky factors the finite-element reference of `lamina validate` (src/validate/fem.cpp) 3-30x
# faster than Eigen's SimplicialLDLT, through BLAS (scripts/setup.sh installs OpenBLAS for it).
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
find_library(CHOLMOD_LIBRARY cholmod REQUIRED)

if(LAMINA_BUILD_TESTS)
  find_package(GTest 1.12 REQUIRED CONFIG)
  include(GoogleTest)
endif()
if(LAMINA_BUILD_BENCHMARKS)
  find_package(benchmark 1.7 REQUIRED)
endif()

# Rendering and the viewer (render module only): GLFW windows, libepoxy as the GL and EGL loader
# (Debian's GLEW only works with GLX), Dear ImGui with its GLFW and OpenGL 3 backends prebuilt
# in Debian's libimgui.a, and stb_image_write (prebuilt in libstb).
find_package(glfw3 3.3 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)

# Embedding (docs/embedding.md). The Python module is built for Debian's own Python 3.11, whose
# numpy and pytest come from Debian's packages: not for whatever `python3` is first on PATH (a
# pyenv one here), which has neither. pybind11 2.10 finds the interpreter it is given.
option(LAMINA_PYTHON "Build the Python module (pybind11; docs/python.md)" ON)
if(LAMINA_PYTHON)
  if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
    set(Python3_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "The Python the module is built for")
  endif()
  find_package(Python3 3.9 REQUIRED COMPONENTS Interpreter Development.Module NumPy)
  set(PYBIND11_FINDPYTHON ON)
  find_package(pybind11 2.10 REQUIRED CONFIG)
endif()
# OpenIGTLink 1.11 (`lamina serve`, docs/openigtlink.md): Debian installs its package outside
# CMake's search path.
find_package(OpenIGTLink REQUIRED PATHS /usr/lib/openigtlink NO_DEFAULT_PATH)
# `lamina serve --web` (docs/web.md): Boost.Beast and Boost.Asio, header-only.
find_package(Boost 1.74 REQUIRED)
find_package(OpenSSL 3 REQUIRED)
