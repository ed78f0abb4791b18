# Test settings of the sanitizer build, included by the top-level CMakeLists.txt before
# tests/ and benchmarks/ so that both directories see them (a variable set in tests/ would not
# reach benchmarks/: bench.scaling_two_ranks_short ran without its suppressions).
# The sanitizer build (FABRICA_SANITIZE=ON; README, "Sanitizer build"): every test runs with
# LeakSanitizer's suppressions for the memory the MPI stack keeps until exit
# (tests/sanitizer/lsan.supp), and with its timeout times FABRICA_TEST_TIME_FACTOR
# (ctest's default 1500 s where a test sets none). Nothing changes in other builds.
# fast_unwind_on_malloc=0: Open MPI's libraries have no frame pointers and its components are
# unloaded before the leak check, so the fast unwinder stops at an "<unknown module>" frame that
# no suppression can name; the full unwinder reaches libmpi / libopen-rte / libopen-pal.
# The unit tests (gtest_discover_tests) never start MPI: they get the suppressions only.
if(FABRICA_SANITIZE)
  # Empty (the default): 10, or 25 with Debug. At 4, mpi.output.tiny_two_ranks timed out (240 s)
  # on a 2-core machine shared with two other builds; the factor only delays the report of a
  # real hang. Computed at every configure, so a change of CMAKE_BUILD_TYPE takes effect.
  set(FABRICA_SANITIZE_TIMEOUT_FACTOR "" CACHE STRING
      "Test timeouts are multiplied by this under the sanitizers (empty: 10, 25 with Debug)")
  if(FABRICA_SANITIZE_TIMEOUT_FACTOR)
    set(FABRICA_TEST_TIME_FACTOR ${FABRICA_SANITIZE_TIMEOUT_FACTOR})
  elseif(CMAKE_BUILD_TYPE STREQUAL "Debug")
    set(FABRICA_TEST_TIME_FACTOR 25)
  else()
    set(FABRICA_TEST_TIME_FACTOR 10)
  endif()
  set(FABRICA_SANITIZER_LSAN
      "LSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/tests/sanitizer/lsan.supp:print_suppressions=0")
  # FABRICA_TEST_TIME_FACTOR: the test scripts (tests/cli/*.sh) multiply their own waits and
  # hang limits by it (1 when unset, as in every other build).
  set(FABRICA_SANITIZER_ENV "${FABRICA_SANITIZER_LSAN}" "ASAN_OPTIONS=fast_unwind_on_malloc=0"
      "FABRICA_TEST_TIME_FACTOR=${FABRICA_TEST_TIME_FACTOR}")
  # A sanitizer report in a test's output fails the test whatever its exit code: the tests that
  # expect a run to fail (expect_error.sh, PASS_REGULAR_EXPRESSION) would otherwise pass on it.
  set(FABRICA_SANITIZER_FAIL_REGEX "ERROR: (Address|Leak)Sanitizer" ": runtime error: ")
  math(EXPR FABRICA_SANITIZER_TIMEOUT "1500 * ${FABRICA_TEST_TIME_FACTOR}")
  set(FABRICA_SANITIZER_PROPERTIES ENVIRONMENT "${FABRICA_SANITIZER_LSAN}" TIMEOUT ${FABRICA_SANITIZER_TIMEOUT})
else()
  set(FABRICA_TEST_TIME_FACTOR 1)
endif()
# The hang limit inside the tests that run fabrica under `timeout` (exit 124 = a hang fails):
# 60 s, times the factor under the sanitizers.
math(EXPR FABRICA_TEST_HANG_SECONDS "60 * ${FABRICA_TEST_TIME_FACTOR}")
# Called in every CMakeLists.txt that adds tests with add_test: applies the above to the tests
# of that directory (a no-op without FABRICA_SANITIZE). The work is deferred to the end of the
# directory, so that a test added below the call gets the settings too (cli.triaxial.equilibration_protocols
# once did not: no suppressions, and its run failed on Open MPI's leaks under ASan).
function(fabrica_sanitizer_test_properties)
  if(NOT FABRICA_SANITIZE)
    return()
  endif()
  cmake_language(DEFER CALL fabrica_sanitizer_apply_test_properties)
endfunction()

function(fabrica_sanitizer_apply_test_properties)
  get_property(tests DIRECTORY PROPERTY TESTS)
  foreach(t IN LISTS tests)
    set_property(TEST ${t} APPEND PROPERTY ENVIRONMENT ${FABRICA_SANITIZER_ENV})
    set_property(TEST ${t} APPEND PROPERTY FAIL_REGULAR_EXPRESSION ${FABRICA_SANITIZER_FAIL_REGEX})
    get_test_property(${t} TIMEOUT timeout)
    if(NOT timeout)
      set(timeout 1500)
    endif()
    math(EXPR timeout "${timeout} * ${FABRICA_TEST_TIME_FACTOR}")
    set_tests_properties(${t} PROPERTIES TIMEOUT ${timeout})
  endforeach()
endfunction()
