# terrain_configure_target(): the one place that sets language level and warnings for our targets.
option(TERRAIN_WERROR "Treat warnings as errors on project targets" ON)
option(TERRAIN_FORCE_ASSERTS "Keep TERRAIN_ASSERT active in release builds" OFF)

function(terrain_configure_target target)
    target_compile_features(${target} PUBLIC cxx_std_20)
    set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
    if(MSVC)
        target_compile_options(${target} PRIVATE /W4)
    else()
        target_compile_options(${target} PRIVATE
            -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion
            -Wnon-virtual-dtor -Wold-style-cast -Wnull-dereference)
    endif()
    if(TERRAIN_PIC AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
        # position-independent, but our functions are never interposed and never exported (the
        # one shared library exports its C ABI by a version script): hidden, so that the code
        # calls and reads them directly, as in a plain executable
        target_compile_options(${target} PRIVATE -fno-semantic-interposition)
        set_target_properties(${target} PROPERTIES
            CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
    endif()
    if(TERRAIN_WERROR)
        set_target_properties(${target} PROPERTIES COMPILE_WARNING_AS_ERROR ON)
    endif()
    if(TERRAIN_FORCE_ASSERTS)
        target_compile_definitions(${target} PUBLIC TERRAIN_FORCE_ASSERTS=1)
    endif()
endfunction()
