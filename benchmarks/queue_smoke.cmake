# Smoke test of tally_bench_queue with tiny numbers, on a temporary SQLite
# file (no server needed): every round must drain its jobs, each done and
# claimed once, and report claim latencies and jobs per second, as JSON and
# as a table (with --no-ingest). Timings are never looked at.
# Run as: cmake -DBENCH=<tally_bench_queue> -P queue_smoke.cmake
cmake_minimum_required(VERSION 3.25)

function(run_bench out_var)
  execute_process(COMMAND "${BENCH}" ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    list(JOIN ARGN " " args)
    message(FATAL_ERROR "tally_bench_queue ${args} exited with ${rc}\n${out}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

function(expect_equal what got want)
  if(NOT "${got}" STREQUAL "${want}")
    message(FATAL_ERROR "${what}: got '${got}', expected '${want}'")
  endif()
endfunction()

set(number "^[0-9]+(\\.[0-9]+)?(e[-+]?[0-9]+)?$")

# 1. JSON: a round per worker count, each drained and checked.
run_bench(json --workers 1,3 --jobs 40 --json)
string(JSON rounds LENGTH "${json}" rounds)
expect_equal("rounds" "${rounds}" 2)
foreach(i 0 1)
  string(JSON workers GET "${json}" rounds ${i} workers)
  string(JSON ok GET "${json}" rounds ${i} check ok)
  string(JSON done GET "${json}" rounds ${i} check statuses done)
  string(JSON max_attempts GET "${json}" rounds ${i} check max_attempts)
  string(JSON runs GET "${json}" rounds ${i} check runs)
  string(JSON claims GET "${json}" rounds ${i} claim count)
  string(JSON per_worker LENGTH "${json}" rounds ${i} jobs_per_worker)
  expect_equal("round ${i} check" "${ok}" ON)
  expect_equal("round ${i} jobs done" "${done}" 40)
  expect_equal("round ${i} max attempts" "${max_attempts}" 1)
  expect_equal("round ${i} runs stored" "${runs}" 40)
  expect_equal("round ${i} claims timed" "${claims}" 40)
  expect_equal("round ${i} workers reported" "${per_worker}" "${workers}")
  foreach(field jobs_per_s)
    string(JSON value GET "${json}" rounds ${i} ${field})
    if(NOT value MATCHES "${number}" OR value EQUAL 0)
      message(FATAL_ERROR "round ${i}: ${field} is '${value}'")
    endif()
  endforeach()
  foreach(field p50_ms p95_ms p99_ms max_ms)
    string(JSON value GET "${json}" rounds ${i} claim ${field})
    if(NOT value MATCHES "${number}")
      message(FATAL_ERROR "round ${i}: claim ${field} is '${value}'")
    endif()
  endforeach()
endforeach()

# 2. The table, finishing jobs without a result.
run_bench(text --workers 2 --jobs 20 --no-ingest)
if(NOT text MATCHES "\n +2 +20 +[0-9]+\\.[0-9]+ +[0-9]+\\.[0-9]+ +[0-9]+\\.[0-9] .* ok\n")
  message(FATAL_ERROR "no table line for 2 workers:\n${text}")
endif()
if(NOT text MATCHES "check, 2 worker\\(s\\): done 20; attempts 1\\.\\.1; runs stored 0")
  message(FATAL_ERROR "no check line for 2 workers:\n${text}")
endif()
