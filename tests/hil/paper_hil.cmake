# The paper program in closed loop over vcan between two processes (`dualv sim --can vcan0`
# and `dualv run --can vcan0`), its candump capture checked, and foreign frames + a drive
# fault during a run (paper_hil.sh; issue 5). Included from tests/hil/CMakeLists.txt.
if(TARGET dualv)
  dualv_add_hil_test(hil_paper
    COMMAND ${CMAKE_CURRENT_LIST_DIR}/paper_hil.sh $<TARGET_FILE:dualv>
            ${PROJECT_SOURCE_DIR}/config/dualv.yaml ${PROJECT_SOURCE_DIR}/config/paper.yaml
    VCANS 1 TIMEOUT 300)
endif()
