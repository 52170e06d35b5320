# The library stack as the build states it: each library may include headers only of the libraries
# it links (directly or through them). The graph comes from the libraries' own link lines (so
# adding a dependency means saying so in CMake); cmake/check_layering.cmake then reads every source
# file's #include "module/..." lines and fails, naming the file and line, on any that reaches a
# library not below it. Included by tests/CMakeLists.txt for native builds only.
set(ef_layer_targets ef_core ef_cpu ef_kernels ef_io ef_synth ef_eval ef_slam ef_nn ef_semantic ef_devices
                     ef_sources ef_pipeline ef_app)
# Each library's folder, as its headers are included ("core/image.h", "platform/cpu/...").
set(ef_layer_dir_ef_core src/core)
set(ef_layer_dir_ef_cpu platform/cpu)
set(ef_layer_dir_ef_kernels src/kernels)
set(ef_layer_dir_ef_io src/io)
set(ef_layer_dir_ef_synth src/synth)
set(ef_layer_dir_ef_eval src/eval)
set(ef_layer_dir_ef_slam src/slam)
set(ef_layer_dir_ef_nn src/nn)
set(ef_layer_dir_ef_semantic src/semantic)
set(ef_layer_dir_ef_devices platform/devices)
set(ef_layer_dir_ef_sources src/sources)
set(ef_layer_dir_ef_pipeline src/pipeline)
set(ef_layer_dir_ef_app firmware_app)

# below_<target>: every library of ours that <target> links, transitively.
function(ef_layer_below target out)
  set(seen)
  set(todo ${target})
  while(todo)
    list(POP_FRONT todo t)
    get_target_property(links ${t} LINK_LIBRARIES)
    if(NOT links)
      continue()
    endif()
    foreach(l IN LISTS links)
      if(l IN_LIST ef_layer_targets AND NOT l IN_LIST seen)
        list(APPEND seen ${l})
        list(APPEND todo ${l})
      endif()
    endforeach()
  endwhile()
  set(${out} "${seen}" PARENT_SCOPE)
endfunction()

# One argument: "folder=allowed folder,allowed folder;..." for every library.
set(ef_layer_spec)
foreach(t IN LISTS ef_layer_targets)
  ef_layer_below(${t} below)
  set(dirs)
  foreach(b IN LISTS below)
    list(APPEND dirs ${ef_layer_dir_${b}})
  endforeach()
  list(JOIN dirs "," dirs_text)
  list(APPEND ef_layer_spec "${ef_layer_dir_${t}}=${dirs_text}")
endforeach()
list(JOIN ef_layer_spec "|" ef_layer_spec_text)
add_test(NAME layering
         COMMAND "${CMAKE_COMMAND}" "-DSOURCE_DIR=${PROJECT_SOURCE_DIR}" "-DSPEC=${ef_layer_spec_text}"
                 -P "${CMAKE_CURRENT_LIST_DIR}/cmake/check_layering.cmake")
set_tests_properties(layering PROPERTIES TIMEOUT 60)
