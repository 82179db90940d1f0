# cmake -DBUILD=<lamina build dir> -DSOURCE=<this folder> -DWORK=<scratch folder>
#       [-DPYTHON=<interpreter>] [-DCCACHE=<ccache> -DCCACHE_BASEDIR=<source dir>] -P consumer_test.cmake
# Installs the build into a fresh prefix, then configures, builds and runs tests/embedding/consumer
# against it, as another project would: only CMAKE_PREFIX_PATH is given.
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    list(JOIN ARGN " " cmd)
    message(FATAL_ERROR "failed (${rc}): ${cmd}")
  endif()
endfunction()

file(REMOVE_RECURSE ${WORK})
set(prefix ${WORK}/prefix)
run(${CMAKE_COMMAND} --install ${BUILD} --prefix ${prefix})
foreach(f bin/lamina include/lamina/c_api.h lib/cmake/lamina/laminaConfig.cmake)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "the install lacks ${f}")
  endif()
endforeach()
# The installed tool finds its libraries from where it is (RPATH $ORIGIN/../lib).
run(${prefix}/bin/lamina --version)
# Compiled through ccache as the project is (cmake/ccache.cmake), when the project used it: the
# prefix and the consumer's source lie under the same base_dir, so another clone's run hits.
set(launcher)
if(CCACHE)
  set(ENV{CCACHE_BASEDIR} ${CCACHE_BASEDIR})
  set(ENV{CCACHE_DEPEND} 1)
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=${CCACHE}
               "-DCMAKE_CXX_FLAGS=-ffile-prefix-map=${CCACHE_BASEDIR}=.")
endif()
run(${CMAKE_COMMAND} -S ${SOURCE}/consumer -B ${WORK}/build -G Ninja -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${prefix} ${launcher})
run(${CMAKE_COMMAND} --build ${WORK}/build)
run(${WORK}/build/poke ${WORK}/poke.png)
file(SIZE ${WORK}/poke.png png_bytes)
if(png_bytes LESS 10000)
  message(FATAL_ERROR "poke.png is only ${png_bytes} bytes")
endif()
# The installed Python package imports from the prefix and finds the prefix's libraries.
if(PYTHON)
  file(GLOB site ${prefix}/lib/python*/dist-packages)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${site}
                          ${PYTHON} -c "import lamina; m = lamina.build_model(); print(lamina.__file__, m)"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "${prefix}")
    message(FATAL_ERROR "the installed Python package did not import from ${site}: ${out}")
  endif()
  message(STATUS "installed Python package: ${out}")
endif()
message(STATUS "consumer built against ${prefix}, ran, and wrote poke.png (${png_bytes} bytes)")
