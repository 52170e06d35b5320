# Warnings for our own targets (not for third-party headers).
function(ef_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter -Werror=return-type
                                           -Werror=uninitialized)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wshadow=local)  # GCC only; clang spells it differently
  endif()
endfunction()
