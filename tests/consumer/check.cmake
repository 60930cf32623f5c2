# Builds tests/consumer four ways, as a user would: with `-I include` alone (the file code by
# -DISIN_IMPLEMENTATION), through add_subdirectory, through find_package(isin CONFIG) after
# `cmake --install`, and through pkg-config after the same install. Each writes and reads a PNG.
# Run as: cmake -DISIN_SOURCE_DIR=… -DWORK_DIR=… -DCXX=… -P check.cmake
set(consumer ${CMAKE_CURRENT_LIST_DIR})
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}")
  endif()
endfunction()

# 1. Only the headers: one compiler call, no CMake, no libraries.
run(${CXX} -std=c++17 -DISIN_IMPLEMENTATION -I ${ISIN_SOURCE_DIR}/include ${consumer}/main.cpp -o ${WORK_DIR}/plain)
run(${WORK_DIR}/plain ${WORK_DIR}/plain.png)

# 2. add_subdirectory(isin).
run(${CMAKE_COMMAND} -S ${consumer} -B ${WORK_DIR}/subdir -DCMAKE_CXX_COMPILER=${CXX}
    -DISIN_VIA_SUBDIRECTORY=${ISIN_SOURCE_DIR})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/subdir)
run(${WORK_DIR}/subdir/consumer ${WORK_DIR}/subdir.png)

# 3. cmake --install, then find_package(isin CONFIG) from the prefix.
run(${CMAKE_COMMAND} -S ${ISIN_SOURCE_DIR} -B ${WORK_DIR}/isin-build -DCMAKE_CXX_COMPILER=${CXX}
    -DISIN_BUILD_TESTS=OFF -DISIN_BUILD_EXAMPLES=OFF)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/isin-build)
run(${CMAKE_COMMAND} --install ${WORK_DIR}/isin-build --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${consumer} -B ${WORK_DIR}/installed -DCMAKE_CXX_COMPILER=${CXX}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/installed)
run(${WORK_DIR}/installed/consumer ${WORK_DIR}/installed.png)

# 4. pkg-config from the same prefix.
set(ENV{PKG_CONFIG_PATH} "${WORK_DIR}/prefix/share/pkgconfig:${WORK_DIR}/prefix/lib/pkgconfig:${WORK_DIR}/prefix/lib64/pkgconfig")
execute_process(COMMAND pkg-config --cflags --libs isin-io RESULT_VARIABLE rc OUTPUT_VARIABLE flags
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pkg-config --cflags --libs isin-io failed")
endif()
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${CXX} ${consumer}/main.cpp ${flags} -o ${WORK_DIR}/pkgconfig)
run(${WORK_DIR}/pkgconfig ${WORK_DIR}/pkgconfig.png)
message(STATUS "consumer: -I include, add_subdirectory, find_package and pkg-config all build and run")
