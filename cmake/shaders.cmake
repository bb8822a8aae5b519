# relief_add_shaders(TARGET file... [GENERATED include...]): compiles each GLSL file to
# SPIR-V with glslangValidator and wraps it as a C header (uint32_t array named after the
# file, dots -> underscores, e.g. hello.tesc -> hello_tesc_spv). A shader that does not
# compile fails the build. GENERATED: includes written at build time (by custom commands
# that OUTPUT them); every shader may include them and is rebuilt when they change.
# TARGET becomes an INTERFACE library whose include directory holds the headers, so no
# shader file is ever looked up at run time.
function(relief_add_shaders target)
  cmake_parse_arguments(ARG "" "" "GENERATED" ${ARGN})
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/spv)
  set(headers)
  # Every shader depends on every shared include: a change to one rebuilds them all.
  file(GLOB includes CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.glsl)
  set(gen_dirs)
  foreach(gen ${ARG_GENERATED})
    get_filename_component(dir ${gen} DIRECTORY)
    list(APPEND gen_dirs -I${dir})
  endforeach()
  list(REMOVE_DUPLICATES gen_dirs)
  foreach(src ${ARG_UNPARSED_ARGUMENTS})
    get_filename_component(name ${src} NAME)
    string(REPLACE "." "_" var ${name})
    set(hdr ${out_dir}/${name}.spv.h)
    add_custom_command(
      OUTPUT ${hdr}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
      COMMAND ${GLSLANG_VALIDATOR} -V --target-env vulkan1.1 --quiet
              -I${CMAKE_CURRENT_SOURCE_DIR} ${gen_dirs} --vn ${var}_spv -o ${hdr}
              ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${src} ${includes} ${ARG_GENERATED}
      COMMENT "glslang ${name}"
      VERBATIM)
    list(APPEND headers ${hdr})
  endforeach()
  add_custom_target(${target}_gen DEPENDS ${headers})
  add_library(${target} INTERFACE)
  add_dependencies(${target} ${target}_gen)
  target_include_directories(${target} INTERFACE ${out_dir})
endfunction()
