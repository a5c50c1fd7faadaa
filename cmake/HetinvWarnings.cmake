# Warnings for the project's own targets: hetinv_target_warnings(<target>).
set(HETINV_WARNING_FLAGS
    -Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes -Wmissing-prototypes
    -Wcast-qual -Wformat=2 -Wundef -Wvla -Wdouble-promotion -Wnull-dereference)
if(HETINV_WERROR)
  list(APPEND HETINV_WARNING_FLAGS -Werror)
endif()

function(hetinv_target_warnings target)
  target_compile_options(${target} PRIVATE ${HETINV_WARNING_FLAGS})
endfunction()
