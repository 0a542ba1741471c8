# A command line that must fail as bad input (called by ctest, see
# CMakeLists.txt): PROGRAM run with ARGS (a ;-list) in a fresh WORKDIR must
# exit with status 1 and print exactly the line in REFERENCE on stderr.
include(${CMAKE_CURRENT_LIST_DIR}/test_helpers.cmake)
file(REMOVE_RECURSE ${WORKDIR})
file(MAKE_DIRECTORY ${WORKDIR})
set(ENV{TMPDIR} ${WORKDIR})
execute_process(COMMAND ${PROGRAM} ${ARGS}
  WORKING_DIRECTORY ${WORKDIR}
  RESULT_VARIABLE status
  OUTPUT_QUIET
  ERROR_VARIABLE errors)
if(NOT status EQUAL 1)
  message(FATAL_ERROR "expected exit status 1, got ${status}:\n${errors}")
endif()
expect_error_line(${REFERENCE} "${errors}")
