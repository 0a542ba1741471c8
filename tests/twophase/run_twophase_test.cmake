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

if(MODE STREQUAL "resume")
  run_program(2 ${PROGRAM} ${prm_name}
    --set "Nonlinear solver/Maximum iterations=2"
    --set "Time stepping/Minimal time step=2500"
    --set "Time stepping/Checkpoint interval=4")
  # It must go on from the checkpoint of step 4, not start anew.
  resume_and_compare("Resuming at t = 10000 yr \\(step 4\\)"
    ${PROGRAM} ${prm_name})
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
