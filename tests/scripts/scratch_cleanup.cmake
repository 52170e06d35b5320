# Test binaries remove the scratch folders of passing tests (tests/test_main.cpp): the TumSource
# tests run twice under a private TMPDIR, once with EF_KEEP_TEST_FILES=1 (the folders must be there,
# so the tests do write under TMPDIR) and once without (nothing may be left). Included by
# tests/CMakeLists.txt for native builds only.
add_test(NAME scratch_cleanup
         COMMAND "${CMAKE_COMMAND}"
                 -DTEST_BINARY=$<TARGET_FILE:test_io>
                 -DFILTER=TumSource.*
                 -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/scratch_cleanup
                 -P "${CMAKE_CURRENT_LIST_DIR}/cmake/check_scratch_cleanup.cmake")
set_tests_properties(scratch_cleanup PROPERTIES TIMEOUT 120)
