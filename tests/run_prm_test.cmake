# Run one .prm test (called by ctest, see CMakeLists.txt).
#   KIND = run:   the program must succeed, with no failure and no non-finite
#                 number in output/summary.json, which gives the peak
#                 resident memory; output/convergence.txt is
#                 compared with REFERENCE by numdiff (relative 1e-6,
#                 absolute 1e-12).
#   KIND = input: the program must fail with exit status 1, print exactly the
#                 line in REFERENCE on stderr, and write no result.
include(${CMAKE_CURRENT_LIST_DIR}/test_helpers.cmake)
prepare_work_directory()

set(command ${PROGRAM} ${prm_name})
if(NP GREATER 1)
  set(command ${MPIEXEC} ${MPIEXEC_FLAGS} -np ${NP} ${command})
endif()

if(KIND STREQUAL "run")
  run_program(0 ${command})
  # A run that succeeds has said so in its summary, with finite numbers
  # only (the writer turns NaN and infinities into null).
  file(READ ${WORKDIR}/output/summary.json summary)
  if(summary MATCHES "\"status\": \"failed\"" OR summary MATCHES "null")
    message(FATAL_ERROR "summary.json reports a failure or a non-finite number")
  endif()
  # ... and the most memory it held, by which users size their next run.
  if(NOT summary MATCHES "\"peak_resident_bytes\": [1-9][0-9]*")
    message(FATAL_ERROR "summary.json does not give the peak resident memory")
  endif()
  compare_table(${REFERENCE} ${WORKDIR}/output/convergence.txt
    "output/convergence.txt")
elseif(KIND STREQUAL "input")
  run_program(1 ${command})
  expect_error_line(${REFERENCE} "${errors}")
  if(EXISTS ${WORKDIR}/output)
    file(GLOB_RECURSE written ${WORKDIR}/output/*)
    message(FATAL_ERROR "bad input left an output directory: ${written}")
  endif()
else()
  message(FATAL_ERROR "unknown test kind ${KIND}")
endif()
