# A file that renders a StandardScene, compiled as isin::io's users are (ISIN_COMPILED), compiles
# neither the renderer nor the scene's traversals (include/isin/detail/compiled.hpp): its object
# file defines no render_rows and no Scene<…>::intersect. The same file compiled without
# ISIN_COMPILED defines both, which shows that the check can fail.
# Run as: cmake -DCXX=… -DNM=… -DISIN_SOURCE_DIR=… -DWORK_DIR=… -P compiled_once.cmake
file(MAKE_DIRECTORY ${WORK_DIR})
set(source ${ISIN_SOURCE_DIR}/examples/notes_scene.cpp)
foreach(way compiled alone)
  set(defines)
  if(way STREQUAL "compiled")
    set(defines -DISIN_COMPILED)
  endif()
  execute_process(COMMAND ${CXX} -std=c++17 -O0 ${defines} -I ${ISIN_SOURCE_DIR}/include -c ${source}
                          -o ${WORK_DIR}/${way}.o
                  RESULT_VARIABLE rc ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "compiling ${source} (${way}) failed:\n${out}")
  endif()
  execute_process(COMMAND ${NM} -C --defined-only ${WORK_DIR}/${way}.o RESULT_VARIABLE rc OUTPUT_VARIABLE symbols)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${NM} failed on ${WORK_DIR}/${way}.o")
  endif()
  string(REGEX MATCH "isin::render_rows<[^\n]*|isin::Scene<[^\n]*>::intersect\\([^\n]*" found "${symbols}")
  if(way STREQUAL "compiled" AND found)
    message(FATAL_ERROR "with ISIN_COMPILED, notes_scene.cpp compiled what isin::io holds: ${found}")
  elseif(way STREQUAL "alone" AND NOT found)
    message(FATAL_ERROR "without ISIN_COMPILED, notes_scene.cpp defines no render_rows: the check sees nothing")
  endif()
endforeach()
message(STATUS "compiled once: a StandardScene's renderer comes from isin::io, not from the file that renders")
