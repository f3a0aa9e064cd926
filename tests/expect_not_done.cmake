# Checks an untouched starting point: its program and its tests must fail, naming an exercise.
# cmake -DPROGRAM=... -DTESTS=... -DSTAGE=NN -DSCENE=... -P expect_not_done.cmake
set(pattern "stage ${STAGE}: EXERCISE [0-9]+ \\([^)]+\\) is not done yet")
execute_process(COMMAND ${PROGRAM} ${SCENE} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 4 AND err MATCHES "no CUDA device")
  message(STATUS "skipped: no CUDA device (the starting point of stage ${STAGE} built; it needs a GPU to run)")
  return()
endif()
if(rc EQUAL 0 OR NOT err MATCHES "${pattern}")
  message(FATAL_ERROR "plab run on the starting point of stage ${STAGE} should stop with "
                      "'stage ${STAGE}: EXERCISE n (...) is not done yet'; it exited ${rc} with:\n${err}")
endif()
string(REGEX MATCH "${pattern}" said "${err}")
message(STATUS "starting point of stage ${STAGE}, run: ${said}")
execute_process(COMMAND ${TESTS} --gtest_brief=1 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT "${out}${err}" MATCHES "${pattern}")
  message(FATAL_ERROR "the tests of the starting point of stage ${STAGE} should fail with the "
                      "'not done yet' message; they exited ${rc} with:\n${out}${err}")
endif()
message(STATUS "starting point of stage ${STAGE}, tests: fail as they should")
