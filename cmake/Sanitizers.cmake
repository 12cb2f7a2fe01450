# TERRAIN_SANITIZE=address,undefined applies to every target in the build (our code and tests).
set(TERRAIN_SANITIZE "" CACHE STRING "Sanitizers to enable, e.g. address,undefined")
if(TERRAIN_SANITIZE)
    add_compile_options(-fsanitize=${TERRAIN_SANITIZE} -fno-sanitize-recover=all -fno-omit-frame-pointer)
    add_link_options(-fsanitize=${TERRAIN_SANITIZE})
endif()
