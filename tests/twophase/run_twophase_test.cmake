# Tests of step-twophase that need two runs or an MPI launch, which the
# generic runner (tests/run_prm_test.cmake) does not do. Registered by
# step-twophase/CMakeLists.txt.
#   MODE = resume:      run PRM with Newton limited to 2 iterations, so that
#                       it fails (exit status 2) at the first step with gas,
#                       after a checkpoint at step 4; then resume it with the
#                       file's own settings. output/convergence.txt must be
#                       REFERENCE, the table of the uninterrupted run.
#   MODE = serial-only: run PRM on 2 MPI ranks: exit status 1, exactly the
#                       line of REFERENCE on stderr, nothing written.
include(${CMAKE_CURRENT_LIST_DIR}/../test_helpers.cmake)
prepare_work_directory()
# No report of mpirun's own on a non-zero exit status.
set(ENV{OMPI_MCA_orte_execute_quiet} 1)

function(run_program expected_status)
  execute_process(COMMAND ${ARGN}
    WORKING_DIRECTORY ${WORKDIR}
    RESULT_VARIABLE status
    OUTPUT_FILE ${WORKDIR}/screen-output
    ERROR_FILE ${WORKDIR}/error-output)
  file(READ ${WORKDIR}/error-output errors)
  if(NOT status EQUAL ${expected_status})
    message(FATAL_ERROR
      "expected exit status ${expected_status}, got ${status}:\n${errors}")
  endif()
  set(errors "${errors}" PARENT_SCOPE)
endfunction()

if(MODE STREQUAL "resume")
  run_program(2 ${PROGRAM} ${prm_name}
    --set "Nonlinear solver/Maximum iterations=2"
    --set "Time stepping/Minimal time step=2500"
    --set "Time stepping/Checkpoint interval=4")
  if(NOT EXISTS ${WORKDIR}/output/checkpoint.txt)
    message(FATAL_ERROR "the failed run left no checkpoint")
  endif()
  run_program(0 ${PROGRAM} ${prm_name} --set "Time stepping/Resume=true")
  # It must have continued from the checkpoint of step 4, not started anew.
  file(READ ${WORKDIR}/screen-output screen)
  if(NOT screen MATCHES "Resuming at t = 10000 yr \\(step 4\\)")
    message(FATAL_ERROR "the second run did not resume at step 4:\n${screen}")
  endif()
  compare_table(${REFERENCE} ${WORKDIR}/output/convergence.txt
    "the resumed run")
elseif(MODE STREQUAL "serial-only")
  run_program(1 ${MPIEXEC} --allow-run-as-root --oversubscribe -np 2
    ${PROGRAM} ${prm_name})
  expect_error_line(${REFERENCE} "${errors}")
  if(EXISTS ${WORKDIR}/output)
    message(FATAL_ERROR "the run on 2 ranks wrote output/")
  endif()
else()
  message(FATAL_ERROR "unknown MODE ${MODE}")
endif()
