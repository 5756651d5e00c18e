# The fuzz harnesses and what each is built from, declared once for two builds:
# - fuzz/CMakeLists.txt (clang, libFuzzer): dofkit_fuzz_harnesses(fuzz_ "") → fuzz_<name>;
# - the main build with tests: dofkit_fuzz_harnesses(replay_ fuzz/replay_main.cpp) → replay_<name>,
#   run by CTest over the committed corpus (FuzzCorpus.<name>), so a harness that stops
#   compiling or linking, or a corpus file that starts to crash, fails scripts/test and
#   scripts/sanitize, not only a fuzzing run.
# Needs the targets dofkit_io and dofkit_scene, and dofkit_cli_commands (the CLI's
# subcommands without main(), an object library).
set(DOFKIT_FUZZ_HARNESSES load_render exr png jpeg tiff layers render cli json phone CACHE INTERNAL "")
set(_dofkit_fuzz_dir ${CMAKE_CURRENT_LIST_DIR})

function(dofkit_fuzz_harnesses prefix driver)
  set(d ${_dofkit_fuzz_dir})
  add_executable(${prefix}load_render ${d}/fuzz_load_render.cpp ${driver})
  # One target per reader: the same harness, the format's extension; layers = deep and
  # dofkit's layered EXR (io::read_layers).
  foreach(format exr png jpeg tiff layers)
    add_executable(${prefix}${format} ${d}/fuzz_reader.cpp ${driver})
  endforeach()
  target_compile_definitions(${prefix}exr PRIVATE FUZZ_EXTENSION=".exr")
  target_compile_definitions(${prefix}png PRIVATE FUZZ_EXTENSION=".png")
  target_compile_definitions(${prefix}jpeg PRIVATE FUZZ_EXTENSION=".jpg")
  target_compile_definitions(${prefix}tiff PRIVATE FUZZ_EXTENSION=".tif")
  target_compile_definitions(${prefix}layers PRIVATE FUZZ_EXTENSION=".exr" FUZZ_LAYERS=1)
  add_executable(${prefix}render ${d}/fuzz_render.cpp ${driver})
  # Phone photos' embedded depth: XMP, base64, GDepth JPEGs, HEIF depth images.
  add_executable(${prefix}phone ${d}/fuzz_phone.cpp ${driver})
  # The command line: the subcommands exactly as the dofkit executable builds them.
  add_executable(${prefix}cli ${d}/fuzz_cli.cpp ${driver})
  target_link_libraries(${prefix}cli PRIVATE dofkit_cli_commands)
  # The JSON files the commands read (camera.json, ...), through the CLI's own readers.
  add_executable(${prefix}json ${d}/fuzz_json.cpp ${driver})
  target_link_libraries(${prefix}json PRIVATE dofkit_cli_commands)
  foreach(h ${DOFKIT_FUZZ_HARNESSES})
    target_include_directories(${prefix}${h} PRIVATE ${d})
    target_link_libraries(${prefix}${h} PRIVATE dofkit_io dofkit_scene OpenImageIO::OpenImageIO)
  endforeach()
endfunction()
