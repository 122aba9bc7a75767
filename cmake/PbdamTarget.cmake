# Per-target compile settings: warnings as errors on our own targets only (never global flags),
# and the sanitizer selected by PBDAM_SANITIZE.

function(pbdam_target_settings target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion -Wnon-virtual-dtor
    -Wold-style-cast -Wcast-align -Woverloaded-virtual -Wdouble-promotion
    -Wformat=2 -Wimplicit-fallthrough)
  if(PBDAM_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(PBDAM_SANITIZE)
    target_compile_options(${target} PUBLIC -fsanitize=${PBDAM_SANITIZE} -fno-omit-frame-pointer
                                            -fno-sanitize-recover=all)
    # With -fsanitize GCC leaves out the --as-needed Debian's GCC passes by default, and every
    # executable would load every library its dependencies name (OpenImageIO alone brings 260,
    # 0.15 s at each start).
    target_link_options(${target} PUBLIC -fsanitize=${PBDAM_SANITIZE} -Wl,--as-needed)
  endif()
endfunction()

# pbdam_add_library(NAME SOURCES... [DEPS ...]): a module library with public headers under
# <module>/include (installed under include/: cmake/PbdamInstall.cmake).
function(pbdam_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                            $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  pbdam_target_settings(${name})
endfunction()

# pbdam_embed_shaders(TARGET SHADERS...): compiles GLSL to SPIR-V with glslc at build time and
# makes each available as `<name>.<stage>.inc`, a C initializer list of uint32_t words
# (glslc -mfmt=c), in the target's include path; #include it inside a braced array. Shaders may
# `#include` files beside them or in gpu/shaders (GL_GOOGLE_include_directive); glslc's depfile
# makes edits to included files rebuild them.
function(pbdam_embed_shaders target)
  set(outDir ${CMAKE_CURRENT_BINARY_DIR}/shaders)
  file(MAKE_DIRECTORY ${outDir})
  set(outputs)
  foreach(src ${ARGN})
    get_filename_component(fname ${src} NAME)
    set(out ${outDir}/${fname}.inc)
    add_custom_command(OUTPUT ${out}
      COMMAND Vulkan::glslc --target-env=vulkan1.2 -O -Werror -mfmt=c
              -I ${PROJECT_SOURCE_DIR}/gpu/shaders -MD -MF ${out}.d
              -o ${out} ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      DEPFILE ${out}.d
      COMMENT "glslc ${fname}")
    list(APPEND outputs ${out})
  endforeach()
  add_custom_target(${target}_shaders DEPENDS ${outputs})
  add_dependencies(${target} ${target}_shaders)
  target_include_directories(${target} PRIVATE ${outDir})
endfunction()
