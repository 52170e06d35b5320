# Instruction-set handling.
#
# Baselines: x86-64 builds with SSE4.1 everywhere; AArch64 has NEON everywhere. Faster paths live in
# files whose name ends in the ISA suffix (`name__avx2.cpp`), get that ISA's flags here, and are
# chosen at run time by platform/cpu_features. Never -march=native: the binary must run on every
# machine of its architecture (valgrind and many x86 machines lack AVX-512).
#
# Suffixes: __sse41 (baseline) __avx2 __avxvnni __avx512vnni (x86-64); __neon (baseline) __neondot (AArch64).

if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  set(EF_ARCH_X86 ON)
  add_compile_options(-msse4.1)
elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64|ARM64)$")
  set(EF_ARCH_ARM64 ON)
else()
  message(WARNING "EdgeFusion: no SIMD paths for ${CMAKE_SYSTEM_PROCESSOR}; scalar kernels only")
endif()

# ef_filter_isa_sources(<out-var> <sources...>): drops files for the other architecture and sets
# per-file compile flags from the suffix.
function(ef_filter_isa_sources out)
  set(kept)
  foreach(src IN LISTS ARGN)
    get_filename_component(stem "${src}" NAME_WE)
    set(flags "")
    set(keep ON)
    if(stem MATCHES "__(sse41|avx2|avxvnni|avx512vnni)$")
      set(isa "${CMAKE_MATCH_1}")
      if(NOT EF_ARCH_X86)
        set(keep OFF)
      elseif(isa STREQUAL "avx2")
        set(flags "-mavx2;-mfma;-mbmi2")
      elseif(isa STREQUAL "avxvnni")
        set(flags "-mavx2;-mfma;-mavxvnni")
      elseif(isa STREQUAL "avx512vnni")
        set(flags "-mavx512f;-mavx512bw;-mavx512dq;-mavx512vl;-mavx512vnni;-mfma")
      endif()
    elseif(stem MATCHES "__(neon|neondot)$")
      set(isa "${CMAKE_MATCH_1}")
      if(NOT EF_ARCH_ARM64)
        set(keep OFF)
      elseif(isa STREQUAL "neondot")
        set(flags "-march=armv8.2-a+dotprod")
      endif()
    endif()
    if(keep)
      list(APPEND kept "${src}")
      if(flags)
        set_source_files_properties("${src}" PROPERTIES COMPILE_OPTIONS "${flags}")
      endif()
    endif()
  endforeach()
  set(${out} "${kept}" PARENT_SCOPE)
endfunction()
