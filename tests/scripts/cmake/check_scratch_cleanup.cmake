# cmake -DTEST_BINARY=... -DFILTER=... -DWORK_DIR=... -P check_scratch_cleanup.cmake
# (see scratch_cleanup.cmake).
foreach(var TEST_BINARY FILTER WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "check_scratch_cleanup: ${var} is not set")
  endif()
endforeach()

function(run_into tmp keep)
  file(REMOVE_RECURSE "${tmp}")
  file(MAKE_DIRECTORY "${tmp}")
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env "TMPDIR=${tmp}" "EF_KEEP_TEST_FILES=${keep}"
                          "${TEST_BINARY}" "--gtest_filter=${FILTER}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${TEST_BINARY} --gtest_filter=${FILTER} failed (exit ${rc}):\n${out}")
  endif()
endfunction()

run_into("${WORK_DIR}/keep" 1)
file(GLOB kept "${WORK_DIR}/keep/edgefusion-test-*")
list(LENGTH kept n_kept)
if(n_kept EQUAL 0)
  message(FATAL_ERROR "with EF_KEEP_TEST_FILES=1 no scratch folder appeared under ${WORK_DIR}/keep: "
                      "the filter ${FILTER} no longer makes scratch folders, so this check proves nothing")
endif()

run_into("${WORK_DIR}/clean" 0)
file(GLOB left "${WORK_DIR}/clean/*")
if(left)
  message(FATAL_ERROR "passing tests left files in their TMPDIR: ${left}")
endif()
message(STATUS "scratch_cleanup: ${n_kept} folders kept on request, none left without it")
file(REMOVE_RECURSE "${WORK_DIR}")
