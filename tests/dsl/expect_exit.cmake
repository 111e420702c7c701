# Runs `PROGRAM check SCENE [ARGS...]` (ARGS: a ;-list) and fails unless it exits with EXPECT and,
# on failure, prints a file:line:col diagnostic on stderr (matching the regular expression MATCH
# where one is given).
execute_process(COMMAND ${PROGRAM} check ${SCENE} ${ARGS} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL EXPECT)
  message(FATAL_ERROR "fascia check ${SCENE} ${ARGS}: exit ${code}, expected ${EXPECT}\nstderr:\n${err}")
endif()
if(NOT EXPECT EQUAL 0 AND NOT err MATCHES "${SCENE}:[0-9]+:[0-9]+: |[a-z_]+\\.yaml:[0-9]+:[0-9]+: |--set:[0-9]+:[0-9]+: ")
  message(FATAL_ERROR "fascia check ${SCENE}: no file:line:col diagnostic on stderr:\n${err}")
endif()
if(DEFINED MATCH AND NOT err MATCHES "${MATCH}")
  message(FATAL_ERROR "fascia check ${SCENE}: stderr does not match '${MATCH}':\n${err}")
endif()
message(STATUS "exit ${code} as expected\n${err}")
