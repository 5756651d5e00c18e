# Extra test wiring, included by the top CMakeLists.txt after the per-folder GoogleTest
# executables are defined.

# test_cli runs `dofkit render` in-process (chosen while the CLI linked OpenImageIO and each
# process took ~0.25 s to start; it also keeps failures debuggable in one process): it
# compiles the command's sources itself rather than spawning the binary, except for a few
# end-to-end cases that run the built `dofkit` (DOFKIT_BINARY_DIR/dofkit).
if(TARGET test_cli)
  target_sources(test_cli PRIVATE
    ${CMAKE_CURRENT_SOURCE_DIR}/apps/dofkit/cmd_render.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/apps/dofkit/chunks.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/apps/dofkit/cli_common.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/apps/dofkit/budget.cpp)
  target_include_directories(test_cli PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/apps/dofkit)
  # render_phone_test.cpp makes its HEIC files with libheif's encoder.
  if(LIBHEIF_FOUND)
    target_link_libraries(test_cli PRIVATE PkgConfig::LIBHEIF)
    target_compile_definitions(test_cli PRIVATE DOFKIT_HAVE_HEIF=1)
  endif()
endif()
# Tests that run the built `dofkit` and parse its `--json` (bench_cli_test.cpp; the GPU
# backend's tests/gpu_cli/).
foreach(t test_cli test_gpu_cli)
  if(TARGET ${t})
    find_package(nlohmann_json REQUIRED)
    target_link_libraries(${t} PRIVATE nlohmann_json::nlohmann_json)
    if(TARGET dofkit_cli)
      add_dependencies(${t} dofkit_cli)
    endif()
  endif()
endforeach()

# `dofkit view`'s HTTP tests run the built binary and talk to it with cpp-httplib's client.
if(TARGET test_view)
  find_package(PkgConfig REQUIRED)
  pkg_check_modules(CPPHTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
  target_link_libraries(test_view PRIVATE PkgConfig::CPPHTTPLIB nlohmann_json::nlohmann_json)
  if(TARGET dofkit_cli)
    add_dependencies(test_view dofkit_cli)
  endif()
endif()

# `dofkit view` in Debian's chromium, headless, driven by playwright-core (npm; scripts/deps).
# Skipped (exit 77) only when chromium is not installed.
if(TARGET dofkit_cli)
  add_test(NAME View.Browser
    COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tests/browser/run_view_test.sh $<TARGET_FILE:dofkit_cli>
            ${CMAKE_CURRENT_BINARY_DIR}/view-browser-test)
  set_tests_properties(View.Browser PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 300 LABELS "browser")
endif()

# Library users (issue 2 item 8): install this build into a scratch prefix, then configure,
# build and run a tiny project that does find_package(dofkit) and links dofkit::dofkit.
# It needs the whole build (the install rules cover the CLI too), so it runs from CTest after
# a full build, never as part of a partial one.
add_test(NAME install_consumer
  COMMAND ${CMAKE_COMMAND}
    -DDOFKIT_BUILD_DIR=${CMAKE_CURRENT_BINARY_DIR}
    -DCONSUMER_SOURCE_DIR=${CMAKE_CURRENT_SOURCE_DIR}/tests/consumer
    -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/consumer-test
    -DCMAKE_GENERATOR=${CMAKE_GENERATOR}
    -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE}
    -P ${CMAKE_CURRENT_SOURCE_DIR}/tests/consumer/run_consumer_test.cmake)
set_tests_properties(install_consumer PROPERTIES TIMEOUT 600 LABELS "install")

# The fast passes against their oracles once more per narrower SIMD target (issue 8: a release
# binary must be right on any x86-64, not only with the widest kernels of the machine that runs
# the tests). Each entry runs the listed tests of one executable with DOFKIT_SIMD_TARGET set
# (tests/simd_target_main.cpp pins every dispatcher to it); a target the machine cannot run,
# or its default one, is reported as skipped. CTest names: Suite.Test@TARGET.
set(DOFKIT_TEST_SIMD_TARGETS "AVX2;SSE4;SCALAR" CACHE STRING
    "Highway targets whose code paths the fast-versus-plain tests also run (empty: none)")
set(DOFKIT_SIMD_TEST_FILTERS
    "core|Strip.*:CocRange.*:Filters.*"
    "mcguire|Mcguire.FastPassesMatchPlainOracle:Mcguire.G3dPassesMatchPlain:Mcguire.FastPathMatchesPlain:Mcguire.RowKernelsMatchScalarLoops:Mcguire.SameOutputForAnyThreadCount"
    "sterna|SternaFast.*:SternaColourCheck.*:Sterna.SameOutputForOneAndTwoThreads"
    "starcraft|StarcraftFast.*:StarcraftFinal.*:WeightedGaussian.*:Starcraft.SameOutputForAnyThreadCount"
    "layered|LayeredFast.*:LayeredColourCheck.*"
    "reference|Reference.SimdLoop*"
    "lens|LensFast.*"
    "ssao|Ao.FastPathsMatchThePlainOracles:Ao.BlurKernelsMatchTheOracleBitForBit:Ao.SameOutputForAnyThreadCount")
foreach(simd_target ${DOFKIT_TEST_SIMD_TARGETS})
  foreach(entry ${DOFKIT_SIMD_TEST_FILTERS})
    string(REPLACE "|" ";" entry "${entry}")
    list(GET entry 0 exe)
    list(GET entry 1 filter)
    if(TARGET test_${exe})
      gtest_discover_tests(test_${exe} TEST_SUFFIX "@${simd_target}" TEST_FILTER "${filter}"
                           TEST_LIST test_${exe}_${simd_target} DISCOVERY_TIMEOUT 60
                           PROPERTIES TIMEOUT 600 ENVIRONMENT "DOFKIT_SIMD_TARGET=${simd_target}")
    endif()
  endforeach()
endforeach()


# scripts/gpu-check's copy of the GPU parity and validation tests (tests/gpu/), linked without
# the IO stack so that it can run on a machine that has only a Vulkan driver (the binary and
# the few libraries it needs travel there; see scripts/gpu-check --pack). Not a CTest test
# (test_gpu runs the same tests); built only on request.
if(TARGET test_gpu)
  file(GLOB _gpu_check_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/tests/gpu/*.cpp)
  add_executable(gpu_check_tests EXCLUDE_FROM_ALL ${_gpu_check_sources})
  target_include_directories(gpu_check_tests PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src ${CMAKE_CURRENT_SOURCE_DIR}/tests)
  target_link_libraries(gpu_check_tests PRIVATE dofkit dofkit_scene GTest::gtest GTest::gtest_main TBB::tbb)
endif()

# The README's Quick start, command by command, in a temporary folder (tests/readme/).
if(TARGET dofkit_cli)
  find_package(Python3 COMPONENTS Interpreter)
  if(Python3_Interpreter_FOUND)
    add_test(NAME QuickStart.ReadmeCommands
      COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/readme/quickstart_test.py
        --readme ${CMAKE_CURRENT_SOURCE_DIR}/README.md --dofkit $<TARGET_FILE:dofkit_cli>)
    set_tests_properties(QuickStart.ReadmeCommands PROPERTIES TIMEOUT 900)
  endif()
endif()

# The parameter tables of docs/methods/*.md against `dofkit methods --json` (tests/docs/).
if(TARGET dofkit_cli AND Python3_Interpreter_FOUND)
  add_test(NAME Docs.ParameterTablesMatchTheMethods
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/docs/params_doc_test.py
      --dofkit $<TARGET_FILE:dofkit_cli> --docs ${CMAKE_CURRENT_SOURCE_DIR}/docs/methods)
endif()
