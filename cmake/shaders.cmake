# relief_add_shaders(TARGET file... [OPTIMIZE file...] [GENERATED include...]): compiles
# each GLSL file to SPIR-V with glslangValidator, those also listed after OPTIMIZE then with
# spirv-opt -O, and wraps each as a C header (relief-spirv-embed: a uint32_t array named
# after the file, dots -> underscores, e.g. hello.tesc -> hello_tesc_spv). A shader that
# does not compile or validate fails the build. Why spirv-opt, and only where listed: a
# driver compiles the module at every pipeline creation, and lavapipe took 0.82 s for the
# strip bounds' 1.9 MB as glslang writes it, 0.20 s for the 0.7 MB spirv-opt makes of it
# (same results bit for bit); but GPU-assisted validation's instrumentation of the
# optimised LOD passes gave lavapipe SPIR-V it refused ("Invalid back or cross-edge in
# the CFG"), and the other shaders are small (docs/architecture.md).
# GENERATED: includes written at build time (by custom commands that OUTPUT them); every
# shader may include them and is rebuilt when they change.
# TARGET becomes an INTERFACE library whose include directory holds the headers, so no
# shader file is ever looked up at run time.
function(relief_add_shaders target)
  cmake_parse_arguments(ARG "" "" "GENERATED;OPTIMIZE" ${ARGN})
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
  foreach(src ${ARG_UNPARSED_ARGUMENTS} ${ARG_OPTIMIZE})
    get_filename_component(name ${src} NAME)
    string(REPLACE "." "_" var ${name})
    set(hdr ${out_dir}/${name}.spv.h)
    set(spv ${out_dir}/${name}.spv)
    set(optimize)
    set(what "glslang")
    if(src IN_LIST ARG_OPTIMIZE)
      set(optimize COMMAND ${SPIRV_OPT} -O --target-env=vulkan1.1 ${spv} -o ${spv})
      set(what "glslang + spirv-opt")
    endif()
    add_custom_command(
      OUTPUT ${hdr}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
      COMMAND ${GLSLANG_VALIDATOR} -V --target-env vulkan1.1 --quiet
              -I${CMAKE_CURRENT_SOURCE_DIR} ${gen_dirs} -o ${spv}
              ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      ${optimize}
      COMMAND relief-spirv-embed ${spv} ${var}_spv ${hdr}
      DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${src} ${includes} ${ARG_GENERATED} relief-spirv-embed
      COMMENT "${what} ${name}"
      VERBATIM)
    list(APPEND headers ${hdr})
  endforeach()
  add_custom_target(${target}_gen DEPENDS ${headers})
  add_library(${target} INTERFACE)
  add_dependencies(${target} ${target}_gen)
  target_include_directories(${target} INTERFACE ${out_dir})
endfunction()
