# silpose_library(NAME name SOURCES ... LINKS ...): one layer = one library target silpose_<name>,
# alias silpose::<name>. Each layer names what it links, so the layering is checked at link time.
function(silpose_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                         -Wno-sign-conversion -Wno-missing-field-initializers)
  if(SILPOSE_SANITIZE)
    # SILPOSE_SANITIZERS: address,undefined (default) or thread. A sanitizer report fails the
    # program (no recovery), so that a test reporting one fails.
    target_compile_options(${target} PRIVATE -fsanitize=${SILPOSE_SANITIZERS} -fno-sanitize-recover=all
                           -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=${SILPOSE_SANITIZERS})
  endif()
  if(SILPOSE_BUILD_FUZZERS)
    # Coverage feedback for libFuzzer in every silpose target; fuzz/ links -fsanitize=fuzzer.
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
  if(SILPOSE_CLANG_TIDY)
    set_target_properties(${target} PROPERTIES CXX_CLANG_TIDY clang-tidy)
  endif()
endfunction()

function(silpose_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LINKS;PRIVATE_LINKS" ${ARGN})
  set(target silpose_${ARG_NAME})
  add_library(${target} ${ARG_SOURCES})
  add_library(silpose::${ARG_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${ARG_LINKS} PRIVATE ${ARG_PRIVATE_LINKS})
  # The headers use C++20 (std::span, designated initialisers): required of every user too.
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${ARG_NAME} POSITION_INDEPENDENT_CODE ON)
  silpose_warnings(${target})
  if(SILPOSE_SANITIZE)
    # Whatever links an instrumented library needs the sanitizer runtime: also programs built
    # against an installed sanitizer build (silpose.pc says the same).
    target_link_options(${target} INTERFACE -fsanitize=${SILPOSE_SANITIZERS})
  endif()
  install(TARGETS ${target} EXPORT silposeTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/silpose/${ARG_NAME}
          FILES_MATCHING PATTERN "*.h" PATTERN "*_testing.h" EXCLUDE)
endfunction()

# silpose_test(NAME name SOURCES ... LINKS ...): a GoogleTest executable registered with CTest.
function(silpose_test)
  if(NOT SILPOSE_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LINKS;LABELS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LINKS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${ARG_NAME} PRIVATE
    SILPOSE_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data"
    SILPOSE_SAMPLE_MODELS_DIR="${PROJECT_SOURCE_DIR}/data/models")
  silpose_warnings(${ARG_NAME})
  if(SILPOSE_TEST_PER_BINARY)
    # One CTest test per test program: a fixture's shared set-up (a database built once for all
    # its tests) runs once, not once per test as in a process per test.
    add_test(NAME ${ARG_NAME} COMMAND ${ARG_NAME})
    set_tests_properties(${ARG_NAME} PROPERTIES LABELS "${ARG_LABELS}")
    if("slow" IN_LIST ARG_LABELS)
      # Started first in a parallel run, so that the longest programs do not end it alone.
      set_tests_properties(${ARG_NAME} PROPERTIES COST 1000)
    endif()
  else()
    gtest_discover_tests(${ARG_NAME} DISCOVERY_TIMEOUT 60 PROPERTIES LABELS "${ARG_LABELS}")
  endif()
endfunction()

# silpose_sanitizer_runtime(out): the shared sanitizer runtime that the Python module of a sanitizer
# build needs preloaded into the (uninstrumented) interpreter: the address sanitizer's, which holds
# the undefined-behaviour sanitizer's handlers too.
function(silpose_sanitizer_runtime out)
  if(NOT SILPOSE_SANITIZERS MATCHES "address")
    message(FATAL_ERROR "the Python module can be built with SILPOSE_SANITIZERS=address,undefined "
                        "only, not '${SILPOSE_SANITIZERS}': configure with -DSILPOSE_BUILD_PYTHON=OFF")
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    set(_name "libclang_rt.asan-${CMAKE_SYSTEM_PROCESSOR}.so")
  else()
    set(_name "libasan.so")
  endif()
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=${_name}
                  OUTPUT_VARIABLE _path OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT IS_ABSOLUTE "${_path}" OR NOT EXISTS "${_path}")
    message(FATAL_ERROR "${CMAKE_CXX_COMPILER} does not name its shared sanitizer runtime "
                        "${_name}, which the Python tests of a sanitizer build preload")
  endif()
  set(${out} "${_path}" PARENT_SCOPE)
endfunction()
