# Tests of step-parabolic that need two runs or a failing one, which the
# generic runner (tests/run_prm_test.cmake) does not do. Registered by
# step-parabolic/CMakeLists.txt.
#   MODE = resume:  run PRM on NP ranks with "Time stepping/Steps per run =
#                   STOP" (it ends with a checkpoint after STOP steps), then
#                   resume it with Resume = true. It must say that it resumed
#                   at step STOP, and output/convergence.txt must be
#                   REFERENCE, the table of the uninterrupted run.
#   MODE = failure: run PRM with Newton limited to one iteration: exit status
#                   2, stderr beginning with the line of REFERENCE, and a
#                   summary.json with "status": "failed".
include(${CMAKE_CURRENT_LIST_DIR}/../test_helpers.cmake)
prepare_work_directory()
# No report of mpirun's own on a non-zero exit status.
set(ENV{OMPI_MCA_orte_execute_quiet} 1)

set(run ${PROGRAM} ${prm_name})
if(NP GREATER 1)
  set(run ${MPIEXEC} --allow-run-as-root --oversubscribe -np ${NP} ${run})
endif()

if(MODE STREQUAL "resume")
  run_program(0 ${run} --set "Time stepping/Steps per run=${STOP}")
  file(READ ${WORKDIR}/screen-output screen)
  if(NOT screen MATCHES "Stopped after ${STOP} steps")
    message(FATAL_ERROR "the first run did not stop after ${STOP} steps:\n${screen}")
  endif()
  resume_and_compare("Resuming at t = [0-9.e-]+ \\(step ${STOP}\\)" ${run})
elseif(MODE STREQUAL "failure")
  run_program(2 ${run} --set "Nonlinear solver/Maximum iterations=1")
  file(READ ${REFERENCE} expected)
  string(STRIP "${expected}" expected)
  string(FIND "${errors}" "${expected}" position)
  if(NOT position EQUAL 0)
    message(FATAL_ERROR "expected on stderr:\n${expected}...\ngot:\n${errors}")
  endif()
  file(READ ${WORKDIR}/output/summary.json summary)
  if(NOT summary MATCHES "\"status\": \"failed\"")
    message(FATAL_ERROR "summary.json does not say that the run failed")
  endif()
else()
  message(FATAL_ERROR "unknown MODE ${MODE}")
endif()
