# Shared build settings for every dualv target.

add_library(dualv_warnings INTERFACE)
# -Wshadow and -Wconversion on the project's own code (issue 14); the lcm-gen headers are
# system headers. -Wsign-conversion only on the targets that say DUALV_SIGN_CONVERSION ON
# (dualv_sign_conversion below: the wire and the limits, firmware_if and safety); elsewhere
# int indices into std::array / Eigen still warn, and clang's -Wconversion would include it,
# so it is turned off by name there.
target_compile_options(
  dualv_warnings
  INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
            $<IF:$<BOOL:$<TARGET_PROPERTY:DUALV_SIGN_CONVERSION>>,-Wsign-conversion,-Wno-sign-conversion>)
if(DUALV_WERROR)
  target_compile_options(dualv_warnings INTERFACE -Werror)
endif()
if(DUALV_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(DUALV_TSAN)
  if(DUALV_SANITIZE OR DUALV_FUZZ)
    message(FATAL_ERROR "DUALV_TSAN cannot be combined with DUALV_SANITIZE or DUALV_FUZZ (ASan): use a build directory of its own")
  endif()
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()
# libFuzzer (fuzz/CMakeLists.txt): every library instrumented for coverage-guided fuzzing
# with ASan + UBSan; the fuzz targets themselves link -fsanitize=fuzzer (libFuzzer's main).
if(DUALV_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "DUALV_FUZZ needs clang (libFuzzer): configure with CC=clang CXX=clang++")
  endif()
  if(DUALV_SANITIZE)
    message(FATAL_ERROR "DUALV_FUZZ already enables ASan + UBSan: leave DUALV_SANITIZE off")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer
                      -fsanitize-coverage-ignorelist=${PROJECT_SOURCE_DIR}/fuzz/coverage_ignorelist.txt)
  add_link_options(-fsanitize=address,undefined)
endif()

# dualv_sign_conversion(target ...): -Wsign-conversion on these targets too (with -Werror
# when DUALV_WERROR): every implicit signed/unsigned conversion in their own sources is an
# error.
function(dualv_sign_conversion)
  set_target_properties(${ARGN} PROPERTIES DUALV_SIGN_CONVERSION ON)
endfunction()

function(dualv_add_subdirectory_if_present dir)
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${dir}/CMakeLists.txt)
    add_subdirectory(${dir})
  endif()
endfunction()

# dualv_add_library(name ROOT path... SOURCES ... [LIBS ...] [PRIVATE_LIBS ...]): a layer
# library with an include root of its own (docs/architecture.md "Layers"): each ROOT path
# (a folder or a header, relative to the repository) is mapped by a symbolic link to
# ${PROJECT_BINARY_DIR}/include/<name>/<path>, and that folder, not the repository root, is on
# the include path of the library and of whatever links it. So "control/model/kinematics.hpp"
# resolves in dualv_model and the layers that link it, and an include of a layer the library
# does not link fails to compile ("No such file or directory"). LIBS are the libraries its
# public headers include (PUBLIC); PRIVATE_LIBS those only its sources include.
function(dualv_add_library name)
  cmake_parse_arguments(ARG "" "" "ROOT;SOURCES;LIBS;PRIVATE_LIBS" ${ARGN})
  if(NOT ARG_ROOT)
    message(FATAL_ERROR "dualv_add_library(${name}): give ROOT, the folders or headers of the "
                        "repository its headers are included by (e.g. ROOT control/model)")
  endif()
  set(root ${PROJECT_BINARY_DIR}/include/${name})
  file(REMOVE_RECURSE ${root})  # removes the links, never what they point to
  foreach(path ${ARG_ROOT})
    if(NOT EXISTS ${PROJECT_SOURCE_DIR}/${path})
      message(FATAL_ERROR "dualv_add_library(${name}): ROOT ${path} is not in ${PROJECT_SOURCE_DIR}")
    endif()
    get_filename_component(parent ${root}/${path} DIRECTORY)
    file(MAKE_DIRECTORY ${parent})
    file(CREATE_LINK ${PROJECT_SOURCE_DIR}/${path} ${root}/${path} SYMBOLIC)
  endforeach()
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${root})
  target_link_libraries(${name} PUBLIC ${ARG_LIBS} PRIVATE ${ARG_PRIVATE_LIBS} dualv_warnings)
endfunction()

# dualv_optimize_hot_path(target): for the numeric hot paths (the model's kinematics and
# dynamics, the plant's RK4): -O3 in optimised builds (about 10 % faster than -O2 there),
# and math functions that never set errno, so sqrt compiles to one instruction.
function(dualv_optimize_hot_path target)
  target_compile_options(${target} PRIVATE $<$<CONFIG:Release,RelWithDebInfo>:-O3> -fno-math-errno)
endfunction()

# dualv_add_test(name SOURCES ... LIBS ... [LABELS ...]): one GoogleTest binary.
function(dualv_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gmock GTest::gtest_main dualv_warnings)
  # Tests see the whole repository (tests/support/..., any layer); the layers do not.
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_compile_definitions(${name} PRIVATE DUALV_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60)
  # Labels go on the directory (every test in it): gtest_discover_tests' PROPERTIES would
  # split a list of labels into separate, bogus properties.
  if(ARG_LABELS)
    set_property(DIRECTORY APPEND PROPERTY LABELS ${ARG_LABELS})
  endif()
endfunction()
