# Compiles GLSL compute shaders to SPIR-V at build time and embeds them as uint32 arrays.
#
# tsdf_mcl_add_shader(TARGET <lib> SOURCE <file.comp> NAME <symbol> [DEFINES A=1 B ...])
# writes <symbol>.inc (comma-separated SPIR-V words, #include'd by a .cpp) and <symbol>.spvasm (for
# reading) into the binary dir; glslc's depfile makes edits to included .glsl files rebuild it.
set(TSDF_MCL_SHADER_OUT "${CMAKE_BINARY_DIR}/shaders" CACHE INTERNAL "")
file(MAKE_DIRECTORY "${TSDF_MCL_SHADER_OUT}")

function(tsdf_mcl_add_shader)
  cmake_parse_arguments(ARG "" "SOURCE;NAME" "DEFINES" ${ARGN})
  set(src "${CMAKE_CURRENT_SOURCE_DIR}/${ARG_SOURCE}")
  set(inc "${TSDF_MCL_SHADER_OUT}/${ARG_NAME}.inc")
  set(asm "${TSDF_MCL_SHADER_OUT}/${ARG_NAME}.spvasm")
  set(dep "${TSDF_MCL_SHADER_OUT}/${ARG_NAME}.d")
  set(defs "")
  foreach(d IN LISTS ARG_DEFINES)
    list(APPEND defs "-D${d}")
  endforeach()
  # Shaders include the sensor model's GLSL mirror and the host/shader interface, all beside them in shaders/.
  set(flags --target-env=vulkan1.2 -O -Werror -I "${CMAKE_CURRENT_SOURCE_DIR}" ${defs})
  add_custom_command(
    OUTPUT "${inc}" "${asm}"
    COMMAND "${GLSLC}" ${flags} -mfmt=num -MD -MF "${dep}" -MT "${inc}" -o "${inc}" "${src}"
    COMMAND "${GLSLC}" ${flags} -S -o "${asm}" "${src}"
    DEPENDS "${src}"
    DEPFILE "${dep}"
    COMMENT "glslc ${ARG_SOURCE} -> ${ARG_NAME}"
    VERBATIM)
  set_property(GLOBAL APPEND PROPERTY TSDF_MCL_SHADER_INCS "${inc}")
endfunction()
