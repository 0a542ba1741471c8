# Writes OUTPUT (vi/version.h) from TEMPLATE with the project version and
# the git revision of SOURCE_DIR at the time of the call. Run at configure
# time and again before every build (target vi_version), so that run
# headers and summary.json name the commit the binaries were built from;
# configure_file leaves the file untouched when nothing changed, so an
# unchanged revision recompiles nothing.
set(VI_GIT_REVISION "unknown")
if(GIT_EXECUTABLE AND EXISTS "${SOURCE_DIR}/.git")
  execute_process(COMMAND ${GIT_EXECUTABLE} describe --always --dirty
    WORKING_DIRECTORY ${SOURCE_DIR}
    OUTPUT_VARIABLE VI_GIT_REVISION OUTPUT_STRIP_TRAILING_WHITESPACE
    ERROR_QUIET)
endif()
if(VI_GIT_REVISION STREQUAL "")
  set(VI_GIT_REVISION "unknown")
endif()
configure_file(${TEMPLATE} ${OUTPUT} @ONLY)
