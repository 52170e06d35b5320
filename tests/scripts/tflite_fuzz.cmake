# The TFLite reader's fuzzer (tests/fuzz/tflite/fuzz_tflite.py, issue 34): a short smoke run over its
# committed seeds, where .ci/run's libFuzzer smoke runs cannot reach (the reader is Python). Any
# exception from the reader other than its own TFLiteError, or an input over the time limit, fails
# the test. It skips (exit 77) with a message where numpy or the reader cannot be imported. Findings
# go to the build folder, never into the repository. Included by tests/CMakeLists.txt (native only).
add_test(NAME tflite_fuzz_smoke
         COMMAND /usr/bin/python3 "${PROJECT_SOURCE_DIR}/tests/fuzz/tflite/fuzz_tflite.py" --seconds 10
                 --seeds "${PROJECT_SOURCE_DIR}/tests/fuzz/corpus/tflite"
                 --findings "${CMAKE_CURRENT_BINARY_DIR}/tflite_fuzz_findings"
         WORKING_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}")
set_tests_properties(tflite_fuzz_smoke PROPERTIES TIMEOUT 120 SKIP_RETURN_CODE 77
                     ENVIRONMENT "PYTHONDONTWRITEBYTECODE=1")
