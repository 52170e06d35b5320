# The measuring tools of bench/ that compute figures themselves rather than timing the binary (issue
# 30's reference analysis: bench/reference_consistency.py's direct registration, bench/second_reference.py's
# depth-to-colour transform and three-cornered hat) on inputs whose answer is known: bench/tests.
# numpy and python3-opencv from Debian (scripts/install-deps.sh test). Native builds only, not in the
# sanitizer builds (nothing of ours is compiled into it).
if(EF_SANITIZE)
  return()
endif()
add_test(NAME bench_python
         COMMAND /usr/bin/python3 -m unittest discover -s bench/tests -p "test_*.py"
         WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}")
set_tests_properties(bench_python PROPERTIES TIMEOUT 120 ENVIRONMENT "PYTHONDONTWRITEBYTECODE=1")
