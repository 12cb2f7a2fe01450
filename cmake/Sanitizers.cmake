# TERRAIN_SANITIZE=address,undefined applies to every target in the build (our code and tests);
# TERRAIN_SANITIZE_SKIP names checks of those to leave out (the asan preset says which and why).
set(TERRAIN_SANITIZE "" CACHE STRING "Sanitizers to enable, e.g. address,undefined")
set(TERRAIN_SANITIZE_SKIP "" CACHE STRING "Sanitizer checks to leave out, e.g. null,alignment")
if(TERRAIN_SANITIZE)
    add_compile_options(-fsanitize=${TERRAIN_SANITIZE} -fno-sanitize-recover=all -fno-omit-frame-pointer)
    add_link_options(-fsanitize=${TERRAIN_SANITIZE})
    if(TERRAIN_SANITIZE_SKIP)
        add_compile_options(-fno-sanitize=${TERRAIN_SANITIZE_SKIP})
        add_link_options(-fno-sanitize=${TERRAIN_SANITIZE_SKIP})
    endif()
endif()
