# Writes OUT, a C++ program made of README's ```cpp blocks in order: their #include lines at the
# top, the rest in main(), then CHECKS (a file whose statements check what the example did).
# Run at build time (cmake -DREADME=... -DCHECKS=... -DOUT=... -P), so the test compiles the
# README as it is written.
file(READ ${README} text)
# CMake lists split on ';': hide the code's own until each line is written.
string(REPLACE ";" "<semicolon>" text "${text}")
string(REGEX MATCHALL "```cpp\n[^`]*```" blocks "${text}")
list(LENGTH blocks count)
if(count EQUAL 0)
  message(FATAL_ERROR "${README}: no ```cpp block: the README's library example is gone")
endif()
set(includes "")
set(body "")
foreach(block IN LISTS blocks)
  string(REGEX REPLACE "^```cpp\n" "" block "${block}")
  string(REGEX REPLACE "```$" "" block "${block}")
  string(REPLACE "\n" ";" lines "${block}")
  foreach(line IN LISTS lines)
    string(REPLACE "<semicolon>" ";" line "${line}")
    if(line MATCHES "^#include")
      string(APPEND includes "${line}\n")
    else()
      string(APPEND body "  ${line}\n")
    endif()
  endforeach()
endforeach()
file(READ ${CHECKS} checks)
file(WRITE ${OUT}.tmp "// Generated from ${README} by tests/readme/extract_example.cmake: do not edit.\n"
  "${includes}\n#include \"readme_checks.h\"\n\nint main() {\n${body}\n${checks}}\n")
file(COPY_FILE ${OUT}.tmp ${OUT} ONLY_IF_DIFFERENT)
