# Run one .prm test (called by ctest, see CMakeLists.txt).
#   KIND = run:   the program must succeed; output/convergence.txt is compared
#                 with REFERENCE by numdiff (relative 1e-6, absolute 1e-12).
#   KIND = input: the program must fail with exit status 1, print exactly the
#                 line in REFERENCE on stderr, and write no result.
file(REMOVE_RECURSE ${WORKDIR})
file(MAKE_DIRECTORY ${WORKDIR})
# Run from a copy, so that messages name the file without a machine's path.
get_filename_component(prm_name ${PRM} NAME)
configure_file(${PRM} ${WORKDIR}/${prm_name} COPYONLY)

# A session directory of its own for OpenMPI: two MPI processes started at
# the same moment race on creating a shared one under /tmp.
set(ENV{TMPDIR} ${WORKDIR})

set(command ${PROGRAM} ${prm_name})
if(NP GREATER 1)
  set(command ${MPIEXEC} ${MPIEXEC_FLAGS} -np ${NP} ${command})
endif()
execute_process(COMMAND ${command}
  WORKING_DIRECTORY ${WORKDIR}
  RESULT_VARIABLE status
  OUTPUT_FILE ${WORKDIR}/screen-output
  ERROR_FILE ${WORKDIR}/error-output)
file(READ ${WORKDIR}/error-output errors)

if(KIND STREQUAL "run")
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "exit status ${status}:\n${errors}")
  endif()
  execute_process(COMMAND ${NUMDIFF} -q -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt
    RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    execute_process(COMMAND ${NUMDIFF} -r 1e-6 -a 1e-12 -s " \t\n|"
      ${REFERENCE} ${WORKDIR}/output/convergence.txt)
    message(FATAL_ERROR "output/convergence.txt differs from ${REFERENCE}")
  endif()
elseif(KIND STREQUAL "input")
  file(READ ${REFERENCE} expected)
  string(STRIP "${expected}" expected)
  string(STRIP "${errors}" errors)
  if(NOT status EQUAL 1)
    message(FATAL_ERROR "expected exit status 1, got ${status}:\n${errors}")
  endif()
  if(NOT errors STREQUAL expected)
    message(FATAL_ERROR "expected on stderr:\n${expected}\ngot:\n${errors}")
  endif()
  file(GLOB_RECURSE written ${WORKDIR}/output/*)
  if(written)
    message(FATAL_ERROR "bad input wrote results: ${written}")
  endif()
else()
  message(FATAL_ERROR "unknown test kind ${KIND}")
endif()
