# scripts/run.sh's arguments (issue 33, rough edge 7): without --out it maps into out/run (or
# $EF_OUT) with --overwrite; with the user's own --out the arguments go to `edgefusion run` as they
# are (no second --out, no --overwrite of the user's folder). EF_RUN_DRY=1 makes the script print the
# command instead of installing, building and running. Included by tests/CMakeLists.txt (native only).
find_program(EF_BASH bash)
if(EF_BASH)
  add_test(NAME run_sh_arguments
           COMMAND "${CMAKE_COMMAND}" -DBASH=${EF_BASH} -DSCRIPT=${PROJECT_SOURCE_DIR}/scripts/run.sh
                   -P "${CMAKE_CURRENT_LIST_DIR}/cmake/check_run_sh.cmake")
  set_tests_properties(run_sh_arguments PROPERTIES TIMEOUT 30)
endif()
