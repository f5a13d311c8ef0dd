# dualv_add_hil_test(name COMMAND cmd [args...] [TIMEOUT seconds] [VCANS n]
#                    [CLOCKS real virtual] [WORKING_DIRECTORY dir] [LABELS ...])
#
# Registers a ctest test (label "hil") that runs COMMAND where SocketCAN interfaces
# vcan0..vcan<n-1> are up, through tests/hil/run_in_vcan.sh: directly on a host whose kernel
# has vcan, inside Debian's user-mode-linux guest otherwise (build machines, CI). COMMAND may
# use generator expressions ($<TARGET_FILE:tgt>). TIMEOUT (default 300 s) bounds the guest;
# ctest's own timeout is 60 s longer so the wrapper reports the timeout itself. CLOCKS (default
# real) registers a test per clock: `name` on the guest's real clock, `name_virtual_clock` in
# the time-travel guest (run_in_vcan.sh --clock virtual, label hil_virtual_clock; its kernel
# from tests/hil/uml_kernel/build.sh, DUALV_UML_KERNEL, default build/uml-kernel/linux), where
# the scripts excuse no guest timing (hil_lib.sh guest_timing).
# Run them with `ctest -L hil`; exclude them with `ctest -LE hil`.
#
# Usable from any CMakeLists.txt after include(${PROJECT_SOURCE_DIR}/tests/hil/DualvHil.cmake).
include_guard(GLOBAL)

# The LD_PRELOAD shim that lets UML 6.1 run on hosts with AVX-512/AMX (uml_xstate_shim.c).
# It is loaded into linux.uml, so it must not carry sanitizer flags from the build.
add_library(dualv_uml_xstate_shim MODULE ${CMAKE_CURRENT_LIST_DIR}/uml_xstate_shim.c)
set_target_properties(dualv_uml_xstate_shim PROPERTIES PREFIX "" COMPILE_OPTIONS "" LINK_OPTIONS "")
target_link_libraries(dualv_uml_xstate_shim PRIVATE ${CMAKE_DL_LIBS})

# The virtual clock's kernel (tests/hil/uml_kernel/build.sh writes it there by default).
set(DUALV_UML_KERNEL "${CMAKE_CURRENT_LIST_DIR}/../../build/uml-kernel/linux"
    CACHE FILEPATH "time-travel user-mode-linux kernel for HIL tests with CLOCK virtual")

function(dualv_add_hil_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT;VCANS;WORKING_DIRECTORY" "COMMAND;LABELS;CLOCKS" ${ARGN})
  if(NOT ARG_COMMAND)
    message(FATAL_ERROR "dualv_add_hil_test(${name}): COMMAND is required")
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(NOT ARG_VCANS)
    set(ARG_VCANS 1)
  endif()
  if(NOT ARG_CLOCKS)
    set(ARG_CLOCKS real)
  endif()
  if(NOT ARG_WORKING_DIRECTORY)
    set(ARG_WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  endif()
  math(EXPR ctest_timeout "${ARG_TIMEOUT} + 60")
  foreach(clock IN LISTS ARG_CLOCKS)
    if(clock STREQUAL "real")
      set(test_name ${name})
      set(clock_args --clock real)
      set(labels "hil;${ARG_LABELS}")
    elseif(clock STREQUAL "virtual")
      set(test_name ${name}_virtual_clock)
      if(name MATCHES "_virtual_clock$")  # a test of the virtual clock itself
        set(test_name ${name})
      endif()
      set(clock_args --clock virtual --kernel ${DUALV_UML_KERNEL})
      set(labels "hil;hil_virtual_clock;${ARG_LABELS}")
    else()
      message(FATAL_ERROR "dualv_add_hil_test(${name}): CLOCKS are real and/or virtual, not ${clock}")
    endif()
    # Paths from this file's folder, not the caller's: the include guard makes variables set
    # here exist only in the first includer's scope.
    add_test(NAME ${test_name}
      COMMAND ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/run_in_vcan.sh
              --timeout ${ARG_TIMEOUT} --vcans ${ARG_VCANS} ${clock_args}
              --shim $<TARGET_FILE:dualv_uml_xstate_shim> -- ${ARG_COMMAND}
      WORKING_DIRECTORY ${ARG_WORKING_DIRECTORY})
    # 77: run_in_vcan.sh could not run it here (an ASan build inside user-mode-linux, or no
    # time-travel kernel for the virtual clock).
    set_tests_properties(${test_name} PROPERTIES LABELS "${labels}" TIMEOUT ${ctest_timeout}
                                                 SKIP_RETURN_CODE 77)
  endforeach()
endfunction()
