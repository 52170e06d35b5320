# Warnings for our own targets (not for third-party headers).
function(ef_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter -Werror=return-type
                                           -Werror=uninitialized)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wshadow=local)  # GCC only; clang spells it differently
  elseif(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    # `&` and `|` on bools are deliberate in the per-pixel loops (slam/preprocess, fusion's gates): no
    # short circuit, so the loops stay branch-free and vectorise.
    target_compile_options(${target} PRIVATE -Wno-bitwise-instead-of-logical)
  endif()
  # EF_WERROR (CI): any warning fails the build, so the tree stays free of them under GCC and clang.
  if(EF_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
