# Builds tests/consumer five ways, as a user would: with `-I include` alone (the file code by
# -DISIN_IMPLEMENTATION), through add_subdirectory and FetchContent (whose installs must hold
# none of isin's files), through find_package(isin CONFIG) after `cmake --install`, and through
# pkg-config after the same install. None adds -pthread. Each writes and reads a PNG.
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

# 2b. FetchContent, then both installs: only the consumer's own program may land there.
run(${CMAKE_COMMAND} -S ${consumer} -B ${WORK_DIR}/fetched -DCMAKE_CXX_COMPILER=${CXX}
    -DISIN_VIA_FETCHCONTENT=${ISIN_SOURCE_DIR})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/fetched)
run(${WORK_DIR}/fetched/consumer ${WORK_DIR}/fetched.png)
foreach(way subdir fetched)
  run(${CMAKE_COMMAND} --install ${WORK_DIR}/${way} --prefix ${WORK_DIR}/${way}-prefix)
  file(GLOB_RECURSE installed RELATIVE ${WORK_DIR}/${way}-prefix ${WORK_DIR}/${way}-prefix/*)
  if(NOT installed STREQUAL "bin/consumer")
    message(FATAL_ERROR "isin used through ${way} installed files into its user's install: ${installed}")
  endif()
endforeach()

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
message(STATUS "consumer: -I include, add_subdirectory, FetchContent, find_package and pkg-config all build and run")
