# Run by tests/scripts/report_html.cmake: a run's report.html, rendered by headless Chromium.
if(NOT CHROMIUM OR NOT EXISTS "${CHROMIUM}")
  message(FATAL_ERROR "chromium is not installed (scripts/install-deps.sh test installs Debian's chromium)")
endif()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

# A short run of the built-in room with labels: the page has every section filled.
execute_process(COMMAND "${EDGEFUSION}" run --source "synthetic:?frames=60&size=160x120" --resolution 160x120
                        --out "${WORK}/run" --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "edgefusion run failed (${rc}): ${err}")
endif()
if(NOT out MATCHES "report: [^\n]*/run/report.html")
  message(FATAL_ERROR "run did not name its report.html:\n${out}")
endif()
set(page "${WORK}/run/report.html")
file(READ "${page}" html)

# Self-contained: no script, nothing fetched from the network, the picture inline.
foreach(forbidden "<script" "http://" "https://" "src=\"/" "src=\"file:")
  string(FIND "${html}" "${forbidden}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "report.html contains '${forbidden}' (it must be self-contained)")
  endif()
endforeach()
foreach(section "The map" "The camera's path from above" "Mapping rate over the run" "Stages" "Counters"
                "Classes of the map" "Configuration" "data:image/png;base64,iVBORw0KGgo")
  string(FIND "${html}" "${section}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "report.html lacks '${section}'")
  endif()
endforeach()

# Rendered, with the console on stderr (a console message is an "INFO:CONSOLE" line).
execute_process(COMMAND "${CHROMIUM}" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run
                        --disable-background-networking --disable-component-update --disable-sync
                        "--user-data-dir=${WORK}/profile" --enable-logging=stderr --v=0 --window-size=1360,2000
                        "--screenshot=${WORK}/report.png" "file://${page}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "chromium failed (${rc}):\n${err}")
endif()
string(REGEX MATCHALL "[^\n]*:CONSOLE[^\n]*" console "${err}")
if(console)
  message(FATAL_ERROR "the page logged to the console:\n${console}")
endif()
if(NOT EXISTS "${WORK}/report.png")
  message(FATAL_ERROR "chromium wrote no screenshot")
endif()
file(SIZE "${WORK}/report.png" bytes)
if(bytes LESS 50000)
  message(FATAL_ERROR "the screenshot is ${bytes} bytes: the page rendered (nearly) blank")
endif()
message(STATUS "report.html rendered by ${CHROMIUM} with no console message; screenshot ${bytes} bytes")
file(REMOVE_RECURSE "${WORK}/profile")
