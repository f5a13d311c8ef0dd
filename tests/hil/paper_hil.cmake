# The paper program in closed loop over vcan between two processes (`dualv sim --can vcan0`
# and `dualv run --can vcan0`) with the shipped configuration unchanged, its candump capture
# checked, and foreign frames + a drive fault during a run (paper_hil.sh; issues 5 and 12).
# Included from tests/hil/CMakeLists.txt.
if(TARGET dualv)
  dualv_add_hil_test(hil_paper
    COMMAND ${CMAKE_CURRENT_LIST_DIR}/paper_hil.sh $<TARGET_FILE:dualv>
            ${PROJECT_SOURCE_DIR}/config/dualv.yaml ${PROJECT_SOURCE_DIR}/config/paper.yaml
    VCANS 1 TIMEOUT 600 CLOCKS real virtual)  # up to 8 runs (4 attempts of each part): ~200 s on a loaded host
endif()

# check_paper_wire.py on hand-built captures (on the host: no guest, no CAN): every check it
# makes must be able to fail (check_paper_wire_test.py).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_test(NAME check_paper_wire COMMAND ${Python3_EXECUTABLE} -B ${CMAKE_CURRENT_LIST_DIR}/check_paper_wire_test.py)
endif()
