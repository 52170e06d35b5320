# Run by tests/scripts/run_sh.cmake: scripts/run.sh's `edgefusion run` command line in its dry mode.
function(dry expected)
  cmake_parse_arguments(D "" "" "ARGS;ENV" ${ARGN})
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env EF_RUN_DRY=1 ${D_ENV} "${BASH}" "${SCRIPT}" ${D_ARGS}
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "run.sh ${D_ARGS}: exit ${rc}: ${err}")
  endif()
  set(want "build/app/firmware_app/edgefusion run ${expected}")
  if(NOT out STREQUAL want)
    message(FATAL_ERROR "run.sh ${D_ARGS}:\n  got:  ${out}\n  want: ${want}")
  endif()
endfunction()

dry("--source synthetic:?size=320x240 --out out/run --overwrite")
dry("--source 7scenes:x --out out/run --overwrite" ARGS --source 7scenes:x)
dry("--source 7scenes:x --out /tmp/o --overwrite" ARGS --source 7scenes:x ENV EF_OUT=/tmp/o)
# The user's own folder: as given, once, and not overwritten unless asked.
dry("--out /tmp/mine" ARGS --out /tmp/mine)
dry("--source synthetic: --out=/tmp/mine --frames 5" ARGS --source synthetic: --out=/tmp/mine --frames 5)
dry("--out /tmp/mine --overwrite" ARGS --out /tmp/mine --overwrite)
