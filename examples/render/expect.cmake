# Test driver: runs PROGRAM with the arguments ARGS ('|'-separated) and
# checks its exit status (EXPECT_RC) and that its standard output and error
# together contain the text EXPECT_TEXT (if given).
#   cmake -DPROGRAM=... -DARGS=a|b|c -DEXPECT_RC=1 -DEXPECT_TEXT=... -P expect.cmake
string(REPLACE "|" ";" args "${ARGS}")
execute_process(COMMAND "${PROGRAM}" ${args}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("exit status: ${rc}\n--- stdout:\n${out}--- stderr:\n${err}---")
if(NOT "${rc}" STREQUAL "${EXPECT_RC}")
  message(FATAL_ERROR "expected exit status ${EXPECT_RC}, got ${rc}")
endif()
if(DEFINED EXPECT_TEXT AND NOT "${EXPECT_TEXT}" STREQUAL "")
  string(FIND "${out}${err}" "${EXPECT_TEXT}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "the output does not contain: ${EXPECT_TEXT}")
  endif()
endif()
