# The Vulkan compute backend (issue 35, docs/gpu.md). Included by the top CMakeLists.txt.
#
# DOFKIT_VULKAN=ON (default): the shaders under src/gpu/shaders/ (GLSL 450, one file per pass,
# folders mirroring src/methods/) are compiled to SPIR-V with glslc at build time, checked with
# spirv-val, and embedded in libdofkit; Vulkan is loaded at run time through volk (dlopen of
# libvulkan.so.1), so neither the library nor its users link against Vulkan and a machine
# without it still runs every CPU path. DOFKIT_VULKAN=OFF builds src/gpu/gpu_off.cpp only:
# --backend vulkan then fails with a one-line error.
option(DOFKIT_VULKAN "Build the Vulkan compute backend (needs glslc, spirv-val, volk and the Vulkan headers)" ON)

if(NOT DOFKIT_VULKAN)
  target_sources(dofkit PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src/gpu/gpu_off.cpp)
  return()
endif()

enable_language(C)  # volk.c
find_program(DOFKIT_GLSLC glslc)
find_program(DOFKIT_SPIRV_VAL spirv-val)
find_path(DOFKIT_VOLK_DIR volk.h)
find_path(DOFKIT_VULKAN_HEADERS vulkan/vulkan_core.h)
if(NOT DOFKIT_GLSLC OR NOT DOFKIT_SPIRV_VAL OR NOT DOFKIT_VOLK_DIR OR NOT DOFKIT_VULKAN_HEADERS)
  message(FATAL_ERROR "DOFKIT_VULKAN=ON needs glslc, spirv-val, volk.h and the Vulkan headers "
                      "(Debian: glslc spirv-tools libvulkan-volk-dev libvulkan-dev; scripts/deps installs them); "
                      "or configure with -DDOFKIT_VULKAN=OFF")
endif()

set(_gpu_dir ${CMAKE_CURRENT_SOURCE_DIR}/src/gpu)
file(GLOB_RECURSE DOFKIT_SHADERS CONFIGURE_DEPENDS ${_gpu_dir}/shaders/*.comp)
file(GLOB DOFKIT_SHADER_INCLUDES CONFIGURE_DEPENDS ${_gpu_dir}/shaders/common/*.glsl)
set(_spv_files "")
set(_spv_names "")
foreach(src ${DOFKIT_SHADERS})
  file(RELATIVE_PATH rel ${_gpu_dir}/shaders ${src})
  string(REGEX REPLACE "\\.comp$" "" name ${rel})  # e.g. mcguire/horizontal
  set(spv ${CMAKE_CURRENT_BINARY_DIR}/spv/${name}.spv)
  get_filename_component(spv_dir ${spv} DIRECTORY)
  add_custom_command(
    OUTPUT ${spv}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${spv_dir}
    COMMAND ${DOFKIT_GLSLC} --target-env=vulkan1.1 -O -Werror -I ${_gpu_dir}/shaders/common ${src} -o ${spv}
    COMMAND ${DOFKIT_SPIRV_VAL} --target-env vulkan1.1 ${spv}
    DEPENDS ${src} ${DOFKIT_SHADER_INCLUDES}
    COMMENT "glslc + spirv-val ${name}"
    VERBATIM)
  list(APPEND _spv_files ${spv})
  list(APPEND _spv_names ${name})
endforeach()
set(_blobs ${CMAKE_CURRENT_BINARY_DIR}/generated/spirv_blobs.cpp)
add_custom_command(
  OUTPUT ${_blobs}
  COMMAND ${CMAKE_COMMAND} "-DNAMES=${_spv_names}" "-DFILES=${_spv_files}" -DOUT=${_blobs}
          -P ${_gpu_dir}/embed_spirv.cmake
  DEPENDS ${_spv_files} ${_gpu_dir}/embed_spirv.cmake
  COMMENT "embedding ${CMAKE_MATCH_COUNT}SPIR-V modules"
  VERBATIM)

file(GLOB DOFKIT_GPU_SOURCES CONFIGURE_DEPENDS ${_gpu_dir}/*.cpp ${_gpu_dir}/methods/*.cpp)
list(REMOVE_ITEM DOFKIT_GPU_SOURCES ${_gpu_dir}/gpu_off.cpp)
target_sources(dofkit PRIVATE ${DOFKIT_GPU_SOURCES} ${_blobs} ${_gpu_dir}/volk_impl.c)
# Vulkan structs are value-initialised from their sType alone (`VkFooCreateInfo ci{VK_STRUCTURE_TYPE_...}`).
set_source_files_properties(${DOFKIT_GPU_SOURCES} PROPERTIES COMPILE_OPTIONS -Wno-missing-field-initializers)
target_include_directories(dofkit SYSTEM PRIVATE ${DOFKIT_VOLK_DIR} ${DOFKIT_VULKAN_HEADERS})
target_compile_definitions(dofkit PRIVATE VK_NO_PROTOTYPES)
target_link_libraries(dofkit PRIVATE ${CMAKE_DL_LIBS})
