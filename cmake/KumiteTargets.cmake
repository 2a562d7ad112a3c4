# Shared compile settings for every Kumite target.
add_library(kumite_warnings INTERFACE)
target_compile_options(kumite_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
    -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough>)

if(KUMITE_SANITIZE OR KUMITE_FUZZ)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(KUMITE_FUZZ)
  # Instrument every library for coverage; the fuzz binaries add the libFuzzer main.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()

# kumite_build_paths: this checkout's folders (source, build, ../shared/data) for tests,
# benchmarks and tools' defaults, compiled into one generated source; kumite_use_build_paths
# links it and force-includes its header, whose macros KUMITE_SOURCE_DIR, KUMITE_BINARY_DIR
# and KUMITE_SHARED_DATA_DIR give them as std::string. (As -D string defines they made every
# source of those targets differ from clone to clone, and ccache missed them all in CI.)
configure_file(${PROJECT_SOURCE_DIR}/cmake/build_paths/build_paths.cpp.in
               ${PROJECT_BINARY_DIR}/generated/build_paths.cpp @ONLY)
add_library(kumite_build_paths STATIC ${PROJECT_BINARY_DIR}/generated/build_paths.cpp)
target_include_directories(kumite_build_paths PUBLIC ${PROJECT_SOURCE_DIR}/cmake/build_paths)
function(kumite_use_build_paths target)
  target_link_libraries(${target} PRIVATE kumite_build_paths)
  target_compile_options(${target} PRIVATE
    -include ${PROJECT_SOURCE_DIR}/cmake/build_paths/kumite/build_paths.hpp)
endfunction()

# kumite_module(<name> [DEPS targets...]): the library kumite_<name> from <name>/src/*.cpp
# with the public include dir <name>/include (headers under kumite/<name>/).
function(kumite_module name)
  cmake_parse_arguments(M "" "" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB _src CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  if(NOT _src)
    message(FATAL_ERROR "kumite_module(${name}): no sources in ${CMAKE_CURRENT_SOURCE_DIR}/src")
  endif()
  add_library(kumite_${name} STATIC ${_src})
  add_library(kumite::${name} ALIAS kumite_${name})
  target_include_directories(kumite_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                             PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(kumite_${name} PUBLIC ${M_DEPS} PRIVATE ${M_PRIVATE_DEPS} kumite_warnings)
endfunction()

# kumite_tool(<exe> <source> [DEPS ...]): a command-line tool.
function(kumite_tool exe src)
  cmake_parse_arguments(T "" "" "DEPS" ${ARGN})
  add_executable(${exe} ${src})
  target_link_libraries(${exe} PRIVATE ${T_DEPS} kumite_warnings)
endfunction()

# kumite_test(<module> [DEPS ...]): one GoogleTest binary kumite_<module>_tests from
# tests/<module>/*.cpp, its tests registered one by one with CTest.
function(kumite_test module)
  cmake_parse_arguments(T "" "" "DEPS" ${ARGN})
  file(GLOB _src CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  add_executable(kumite_${module}_tests ${_src})
  target_link_libraries(kumite_${module}_tests PRIVATE ${T_DEPS} GTest::gtest GTest::gtest_main
                        GTest::gmock kumite_warnings)
  kumite_use_build_paths(kumite_${module}_tests)
  gtest_discover_tests(kumite_${module}_tests DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS ${module})
endfunction()

# kumite_fuzzer(<name> <source> [DEPS ...]): a libFuzzer target (only with KUMITE_FUZZ=ON and
# clang). Binaries land in <build>/fuzz/<name>; seeds, if any, in the source's
# corpus_<name>/ folder. .ci/run runs each one briefly.
if(KUMITE_FUZZ AND NOT TARGET kumite_fuzzers)
  add_custom_target(kumite_fuzzers)
endif()
function(kumite_fuzzer name src)
  if(NOT KUMITE_FUZZ)
    return()
  endif()
  cmake_parse_arguments(F "" "" "DEPS" ${ARGN})
  add_executable(${name} ${src})
  target_link_libraries(${name} PRIVATE ${F_DEPS} kumite_warnings)
  target_compile_options(${name} PRIVATE -fsanitize=fuzzer)
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/fuzz)
  add_dependencies(kumite_fuzzers ${name})
endfunction()
