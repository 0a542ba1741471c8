# Pieces shared by the test runners (run_prm_test.cmake and the runners of
# single programs, e.g. tests/twophase/run_twophase_test.cmake), included in
# their -P scripts.

# A fresh WORKDIR with a copy of PRM (so that messages name the file without
# a machine's path; sets prm_name) and a link to the meshes/ folder beside
# it, if any (mesh files are named relative to the parameter file), and a
# session directory of its own for OpenMPI: two MPI processes started at the
# same moment race on creating a shared one under /tmp.
macro(prepare_work_directory)
  file(REMOVE_RECURSE ${WORKDIR})
  file(MAKE_DIRECTORY ${WORKDIR})
  get_filename_component(prm_name ${PRM} NAME)
  get_filename_component(prm_directory ${PRM} DIRECTORY)
  configure_file(${PRM} ${WORKDIR}/${prm_name} COPYONLY)
  if(EXISTS ${prm_directory}/meshes)
    file(CREATE_LINK ${prm_directory}/meshes ${WORKDIR}/meshes SYMBOLIC)
  endif()
  set(ENV{TMPDIR} ${WORKDIR})
endmacro()

# Run the command ARGN in WORKDIR (stdout to screen-output, stderr to
# error-output) and fail unless it ends with exit status `expected_status`;
# sets `errors`, the program's stderr, for the caller.
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

# Fail unless the table `produced` equals `reference` to numdiff's relative
# 1e-6 and absolute 1e-12 (printing the differences); `what` names the run.
function(compare_table reference produced what)
  set(numdiff_options -r 1e-6 -a 1e-12 -s " \t\n|")
  execute_process(COMMAND ${NUMDIFF} -q ${numdiff_options}
      ${reference} ${produced}
    RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    execute_process(COMMAND ${NUMDIFF} ${numdiff_options}
      ${reference} ${produced})
    message(FATAL_ERROR "${what} differs from ${reference}")
  endif()
endfunction()

# Fail unless `errors` (the program's stderr) is exactly the line in
# `reference` (or begins with it, if the reference ends in "...").
function(expect_error_line reference errors)
  file(READ ${reference} expected)
  string(STRIP "${expected}" expected)
  string(STRIP "${errors}" errors)
  # A reference that ends in "..." is the beginning of the line (what
  # follows depends on the machine, e.g. the memory it has).
  if(expected MATCHES "\\.\\.\\.$")
    string(LENGTH "${expected}" length)
    math(EXPR length "${length} - 3")
    string(SUBSTRING "${expected}" 0 ${length} expected)
    string(LENGTH "${expected}" length)
    string(SUBSTRING "${errors}" 0 ${length} errors)
  endif()
  if(NOT errors STREQUAL expected)
    message(FATAL_ERROR "expected on stderr:\n${expected}\ngot:\n${errors}")
  endif()
endfunction()

# The second half of a resume test: the first run (ARGN is its command) has
# left a checkpoint; run it again with "Time stepping/Resume = true". Its
# screen must match `resumed` (it went on from the checkpoint, not from the
# start), and output/convergence.txt must be REFERENCE, the table of the
# uninterrupted run.
function(resume_and_compare resumed)
  if(NOT EXISTS ${WORKDIR}/output/checkpoint.txt)
    message(FATAL_ERROR "the first run left no checkpoint")
  endif()
  run_program(0 ${ARGN} --set "Time stepping/Resume=true")
  file(READ ${WORKDIR}/screen-output screen)
  if(NOT screen MATCHES "${resumed}")
    message(FATAL_ERROR
      "the second run did not resume as \"${resumed}\":\n${screen}")
  endif()
  compare_table(${REFERENCE} ${WORKDIR}/output/convergence.txt
    "the resumed run")
endfunction()
