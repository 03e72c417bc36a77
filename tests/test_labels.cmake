# Run by ctest (TEST_INCLUDE_FILES, after the test executables' own lists): gives every
# GoogleTest test its labels from tests/test_labels_list.cmake. Reads nephele_tests_TESTS,
# nephele_gltests_TESTS and the front ends' nephele_app_tests_TESTS and nephele_app_gltests_TESTS
# (NEPHELE_BUILD_APPS), the lists gtest_discover_tests leaves.
# ctest runs this without the project's policies: those of CMake 3.20 (if(... IN_LIST ...)), for this file only.
cmake_policy(PUSH)
cmake_policy(VERSION 3.20)
include("${CMAKE_CURRENT_LIST_DIR}/test_labels_list.cmake")

function(nephele_label_tests executable_label tests)
  foreach(test IN LISTS tests)
    # "Prefix/Suite.Name/param  # GetParam() = ..." -> "Suite" and "Suite.Name/param".
    string(REGEX REPLACE "  # GetParam.*$" "" bare "${test}")
    string(REGEX REPLACE "^[A-Za-z0-9_]+/" "" unprefixed "${bare}")
    string(REGEX REPLACE "\\..*$" "" suite "${unprefixed}")
    set(labels ${executable_label})
    if(executable_label STREQUAL "unit" AND (suite IN_LIST NEPHELE_CLI_SUITES OR unprefixed IN_LIST NEPHELE_CLI_TESTS))
      set(labels cli)
    endif()
    if(suite IN_LIST NEPHELE_SANITIZE_SUITES OR unprefixed MATCHES "HostState|LeavesHostStateUnchanged")
      list(APPEND labels sanitize)
    endif()
    if(bare IN_LIST NEPHELE_SLOW_TESTS)
      list(APPEND labels slow)
      list(APPEND NEPHELE_SLOW_FOUND "${bare}")
    endif()
    # A slow test starts first (ctest -j runs by descending COST when it has no timings of its
    # own yet, as on a clean clone): started last, one would run alone at the end of the run.
    if("slow" IN_LIST labels)
      set_tests_properties("${test}" PROPERTIES LABELS "${labels}" COST 100)
    else()
      set_tests_properties("${test}" PROPERTIES LABELS "${labels}")
    endif()
  endforeach()
  set(NEPHELE_SLOW_FOUND ${NEPHELE_SLOW_FOUND} PARENT_SCOPE)
endfunction()

set(NEPHELE_SLOW_FOUND)
nephele_label_tests(unit "${nephele_tests_TESTS}")
nephele_label_tests(gl "${nephele_gltests_TESTS}")
nephele_label_tests(unit "${nephele_app_tests_TESTS}")
nephele_label_tests(gl "${nephele_app_gltests_TESTS}")
# A slow test renamed or deleted would silently join the sanitizer subset: say which (when the
# front ends' tests are built too: the list names theirs as well).
if(DEFINED nephele_app_tests_TESTS)
  foreach(name IN LISTS NEPHELE_SLOW_TESTS)
    if(NOT name IN_LIST NEPHELE_SLOW_FOUND)
      message(WARNING "tests/test_labels_list.cmake: no test named ${name} (renamed or deleted?)")
    endif()
  endforeach()
endif()
cmake_policy(POP)
