# report.html in headless Chromium (issue 33): `edgefusion run` writes the page, Debian's chromium
# (scripts/install-deps.sh test) renders it to a screenshot with its console logged; the test fails
# on any console message (the page has no script: any message is a fault, such as a broken
# picture), on a page that reaches for the network or runs a script, and without chromium (it
# never skips: CI installs it). Included by tests/CMakeLists.txt for native builds only.
find_program(EF_CHROMIUM NAMES chromium chromium-browser)
add_test(NAME report_html_chromium
         COMMAND "${CMAKE_COMMAND}" -DEDGEFUSION=$<TARGET_FILE:edgefusion> -DCHROMIUM=${EF_CHROMIUM}
                 -DWORK=${CMAKE_CURRENT_BINARY_DIR}/report_html -P "${CMAKE_CURRENT_LIST_DIR}/cmake/check_report_html.cmake")
set_tests_properties(report_html_chromium PROPERTIES TIMEOUT 180)
