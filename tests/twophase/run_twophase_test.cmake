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
file(REMOVE_RECURSE ${WORKDIR})
file(MAKE_DIRECTORY ${WORKDIR})
get_filename_component(prm_name ${PRM} NAME)
configure_file(${PRM} ${WORKDIR}/${prm_name} COPYONLY)
# A session directory of its own for OpenMPI (see run_prm_test.cmake), and
# no report of mpirun's own on a non-zero exit status.
set(ENV{TMPDIR} ${WORKDIR})
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
  execute_process(COMMAND ${NUMDIFF} -q -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt
    RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    execute_process(COMMAND ${NUMDIFF} -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt)
    message(FATAL_ERROR "the resumed run differs from ${REFERENCE}")
  endif()
elseif(MODE STREQUAL "serial-only")
  run_program(1 ${MPIEXEC} --allow-run-as-root --oversubscribe -np 2
    ${PROGRAM} ${prm_name})
  file(READ ${REFERENCE} expected)
  string(STRIP "${expected}" expected)
  string(STRIP "${errors}" errors)
  if(NOT errors STREQUAL expected)
    message(FATAL_ERROR "expected on stderr:\n${expected}\ngot:\n${errors}")
  endif()
  if(EXISTS ${WORKDIR}/output)
    message(FATAL_ERROR "the run on 2 ranks wrote output/")
  endif()
else()
  message(FATAL_ERROR "unknown MODE ${MODE}")
endif()
