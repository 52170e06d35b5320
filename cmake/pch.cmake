# A precompiled header for the modules whose files include Eigen (io, synth, slam, semantic, pipeline,
# sources, devices, the program and the benches): Eigen and the standard headers most files include,
# parsed once per build instead of once per file (about 1.5-2 s of each such file's compile).
#
# One header, built once (target ef_pch) and reused by every module without code-generation options
# of its own; a module with any (-f...: slam's -fno-math-errno, synth's and semantic's
# -ffp-contract=off) gets a copy built with them. The header's inline functions (Eigen's arithmetic
# among them) are compiled with the options the header was built with, not those of the file that
# includes it: synth reused a header built with the default contraction, and on AArch64 (where GCC
# fuses multiply-adds by default) its rooms were no longer bit-identical to x86-64's (the golden
# test under qemu said so; -Winvalid-pch says nothing about -ffp-contract). -fno-math-errno is
# refused outright by both compilers (it defines __NO_MATH_ERRNO__). Files with options of their own
# (an instruction set's flags, `name__avx2.cpp` in cmake/isa.cmake; slam's per-file -ffp-contract
# and -fno-trapping-math) never use it. Modules without Eigen in most of their files (kernels, nn,
# core, cpu) do not use it: loading the header costs about 0.4 s, more than their files' parse.
# Measured: a release build of the libraries, the program and the benches (no tests), 2 cores, side
# by side: 351 s without the header, 294 s with it (compiler time 684 -> 571 s).
# -Winvalid-pch: a header the compiler refuses is a warning (an error with EF_WERROR), never a silent
# fall-back to parsing every file again.
#   EF_PCH=OFF   plain builds (for example to check that each file includes what it uses)
option(EF_PCH "Precompile Eigen and the common standard headers for the modules that include Eigen" ON)

set(EF_PCH_HEADERS
    <Eigen/Core> <Eigen/Geometry>
    <algorithm> <array> <chrono> <cmath> <cstddef> <cstdint> <cstdio> <cstdlib> <cstring>
    <filesystem> <limits> <memory> <optional> <sstream> <string> <string_view> <utility> <vector>)

if(EF_PCH)
  file(WRITE "${CMAKE_BINARY_DIR}/ef_pch_anchor.cpp" "// the precompiled header's own target\n")
  add_library(ef_pch OBJECT "${CMAKE_BINARY_DIR}/ef_pch_anchor.cpp")
  target_link_libraries(ef_pch PRIVATE Eigen3::Eigen)
  target_precompile_headers(ef_pch PRIVATE ${EF_PCH_HEADERS})
endif()

# ef_target_pch(<target>): <target> compiles with the precompiled header (call it after the target's
# compile options are set: a target with -f options gets its own copy).
function(ef_target_pch target)
  if(NOT EF_PCH)
    return()
  endif()
  # -f options beyond those every target has (the sanitizers', from add_compile_options).
  get_target_property(options ${target} COMPILE_OPTIONS)
  get_target_property(shared_options ef_pch COMPILE_OPTIONS)
  set(own OFF)
  foreach(option IN LISTS options)
    if(option MATCHES "^-f" AND NOT option IN_LIST shared_options)
      set(own ON)
    endif()
  endforeach()
  if(own)
    target_precompile_headers(${target} PRIVATE ${EF_PCH_HEADERS})
  else()
    target_precompile_headers(${target} REUSE_FROM ef_pch)
  endif()
  target_compile_options(${target} PRIVATE -Winvalid-pch)
  get_target_property(srcs ${target} SOURCES)
  foreach(src IN LISTS srcs)
    get_source_file_property(src_options "${src}" COMPILE_OPTIONS)
    if(src_options)
      set_source_files_properties("${src}" PROPERTIES SKIP_PRECOMPILE_HEADERS ON)
    endif()
  endforeach()
endfunction()
