# Warnings for our own targets (not for third-party headers).
function(ef_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter -Werror=return-type
                                           -Werror=uninitialized -Wshadow=local)
endfunction()
