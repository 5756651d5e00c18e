# cmake -P script: install a dofkit build into WORK_DIR/prefix, build the consumer project in
# tests/consumer against it with find_package(dofkit), and run it; then run the installed
# `dofkit` on a call that needs the OpenImageIO module (a PIZ-compressed EXR output) and check, through the
# dynamic loader's own log (LD_DEBUG=files), that it loaded the installed module from
# <prefix>/<libdir>/dofkit/, not the build tree's.
# Inputs: DOFKIT_BUILD_DIR, CONSUMER_SOURCE_DIR, WORK_DIR, CMAKE_GENERATOR, CMAKE_BUILD_TYPE.
cmake_minimum_required(VERSION 3.20)
foreach(var DOFKIT_BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "run_consumer_test.cmake: ${var} not set")
  endif()
endforeach()
if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release)
endif()
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "${what}: ok")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

run_step("install" ${CMAKE_COMMAND} --install "${DOFKIT_BUILD_DIR}" --prefix "${prefix}")
foreach(f include/dofkit/dofkit.hpp)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "install is missing ${f}")
  endif()
endforeach()
file(GLOB_RECURSE configs "${prefix}/*/dofkitConfig.cmake")
if(NOT configs)
  message(FATAL_ERROR "install has no dofkitConfig.cmake")
endif()
set(gen_args)
if(CMAKE_GENERATOR)
  set(gen_args -G "${CMAKE_GENERATOR}")
endif()
# Only the install prefix on the search path: the consumer must not pick up the build tree.
run_step("configure consumer" ${CMAKE_COMMAND} -S "${CONSUMER_SOURCE_DIR}" -B "${WORK_DIR}/build" ${gen_args}
         -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE} "-DCMAKE_PREFIX_PATH=${prefix}" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
run_step("build consumer" ${CMAKE_COMMAND} --build "${WORK_DIR}/build")
run_step("run consumer" "${WORK_DIR}/build/consumer")
message(STATUS "${step_output}")

set(dofkit_exe "${prefix}/bin/dofkit")
file(GLOB installed_module "${prefix}/*/dofkit/libdofkit_oiio.so")
if(NOT installed_module)
  message(FATAL_ERROR "install has no <libdir>/dofkit/libdofkit_oiio.so")
endif()
run_step("installed dofkit writes a frame" "${dofkit_exe}" bench --size 64x36 --write-frame "${WORK_DIR}/frame")
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files "${dofkit_exe}" render --color "${WORK_DIR}/frame/color.exr"
          --depth "${WORK_DIR}/frame/depth.exr" --focus 4 --blur-at-infinity 2 --compression piz
          --output "${WORK_DIR}/frame/out.exr"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS "${WORK_DIR}/frame/out.exr")
  message(FATAL_ERROR "installed dofkit could not write a PIZ EXR (${rc}):\n${err}")
endif()
string(REGEX MATCH "file=[^ \n]*libdofkit_oiio\\.so" loaded "${err}")
if(NOT loaded STREQUAL "file=${installed_module}")
  message(FATAL_ERROR "installed dofkit loaded '${loaded}', expected file=${installed_module}")
endif()
message(STATUS "installed dofkit loaded ${installed_module}: ok")

