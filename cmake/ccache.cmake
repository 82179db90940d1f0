# Every compile goes through ccache when it is installed (scripts/setup.sh installs it; without it
# the build is the same, only uncached). docs/testing.md, "Cached builds and CI's time", has the
# measurements.
#
# A fresh clone at another path must hit what an earlier clone compiled (.ci/run in ../ci-check
# after a build in the working checkout), so nothing a compile sees may name the checkout's path:
# - base_dir = the source tree: ccache hashes the absolute paths under it on the command line
#   (sources, -I, the build tree inside it) as paths relative to the build directory, the same in
#   every clone;
# - -ffile-prefix-map=<source>=. keeps the path out of debug info and __FILE__, and lets ccache
#   hash the mapped working directory instead of the real one when compiling with -g;
# - no compile definition carries an absolute path (tests/support/test_paths.h resolves the test
#   programs' paths at run time instead).
# The cache itself is ccache's default (~/.cache/ccache, 5 GB), shared by every clone and preset on
# the machine (all four presets took 107 MB).
option(LAMINA_CCACHE "Compile through ccache when it is installed" ON)

# The ccache in use, or empty: the builds the tests make (the installed-package consumer) use it too.
set(LAMINA_CCACHE_USED "")
if(LAMINA_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  find_program(LAMINA_CCACHE_PROGRAM ccache)
  if(LAMINA_CCACHE_PROGRAM)
    # ccache 4.7 (Debian 12) reads its settings from the environment, not from its command line.
    # depend mode: a miss compiles once, without a separate preprocessor run to hash (the -MD
    # output every Ninja compile writes is what it hashes instead).
    set(launcher ${CMAKE_COMMAND} -E env CCACHE_BASEDIR=${PROJECT_SOURCE_DIR} CCACHE_DEPEND=1
        ${LAMINA_CCACHE_PROGRAM})
    set(CMAKE_C_COMPILER_LAUNCHER ${launcher})
    set(CMAKE_CXX_COMPILER_LAUNCHER ${launcher})
    set(LAMINA_CCACHE_USED ${LAMINA_CCACHE_PROGRAM})
    message(STATUS "Compiling through ${LAMINA_CCACHE_PROGRAM} (base_dir ${PROJECT_SOURCE_DIR})")
  endif()
endif()
add_compile_options(-ffile-prefix-map=${PROJECT_SOURCE_DIR}=.)
