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
file(REMOVE_RECURSE ${WORKDIR})
file(MAKE_DIRECTORY ${WORKDIR})
get_filename_component(prm_name ${PRM} NAME)
configure_file(${PRM} ${WORKDIR}/${prm_name} COPYONLY)
# A session directory of its own for OpenMPI (see run_prm_test.cmake), and
# no report of mpirun's own on a non-zero exit status.
set(ENV{TMPDIR} ${WORKDIR})
set(ENV{OMPI_MCA_orte_execute_quiet} 1)

set(launcher)
if(NP GREATER 1)
  set(launcher ${MPIEXEC} --allow-run-as-root --oversubscribe -np ${NP})
endif()

function(run_program expected_status)
  execute_process(COMMAND ${launcher} ${PROGRAM} ${prm_name} ${ARGN}
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
  run_program(0 --set "Time stepping/Steps per run=${STOP}")
  if(NOT EXISTS ${WORKDIR}/output/checkpoint.txt)
    message(FATAL_ERROR "the stopped run left no checkpoint")
  endif()
  file(READ ${WORKDIR}/screen-output screen)
  if(NOT screen MATCHES "Stopped after ${STOP} steps")
    message(FATAL_ERROR "the first run did not stop after ${STOP} steps:\n${screen}")
  endif()
  run_program(0 --set "Time stepping/Resume=true")
  file(READ ${WORKDIR}/screen-output screen)
  if(NOT screen MATCHES "Resuming at t = [0-9.e-]+ \\(step ${STOP}\\)")
    message(FATAL_ERROR "the second run did not resume at step ${STOP}:\n${screen}")
  endif()
  execute_process(COMMAND ${NUMDIFF} -q -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt
    RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    execute_process(COMMAND ${NUMDIFF} -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt)
    message(FATAL_ERROR "the resumed run differs from ${REFERENCE}")
  endif()
elseif(MODE STREQUAL "failure")
  run_program(2 --set "Nonlinear solver/Maximum iterations=1")
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
