# Smoke test of tally_bench_read_latency with tiny numbers: it must fill a
# database, answer every route with 200s and report figures for each route
# with 1 and 8 clients, as JSON and as a table (over the kept database,
# --reuse). Timings are never looked at.
# Run as: cmake -DBENCH=<tally_bench_read_latency> -P read_latency_smoke.cmake
cmake_minimum_required(VERSION 3.25)
set(routes
  "GET /api/runs?limit=50"
  "GET /api/runs?renderer=R&limit=50"
  "GET /api/runs?width=W&height=H&limit=50"
  "GET /api/runs?device=D&limit=50"
  "GET /api/runs?device=NAME&limit=50"
  "GET /api/runs?scene=S&limit=50"
  "GET /api/runs?capture=C&limit=50"
  "GET /api/runs?limit=1000 (every page, to the end)"
  "GET /api/runs/{id}"
  "GET /api/runs/{id}/samples"
  "GET /api/samples/{id}")
set(db "${CMAKE_CURRENT_BINARY_DIR}/read_latency_smoke.db")

function(remove_db)
  file(REMOVE "${db}" "${db}-wal" "${db}-shm")
endfunction()

function(run_bench out_var)
  execute_process(COMMAND "${BENCH}" ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    remove_db()
    list(JOIN ARGN " " args)
    message(FATAL_ERROR "tally_bench_read_latency ${args} exited with ${rc}\n${out}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

function(expect_equal what got want)
  if(NOT "${got}" STREQUAL "${want}")
    remove_db()
    message(FATAL_ERROR "${what}: got '${got}', expected '${want}'")
  endif()
endfunction()

remove_db()

# 1. JSON: every route twice (1 and 8 clients), each with requests timed and none failed.
run_bench(json --samples 500 --requests 20 --seconds 60 --db "${db}" --json)
string(JSON samples GET "${json}" database rows samples)
expect_equal("samples stored" "${samples}" 500)
string(JSON problems GET "${json}" plan_problems)
expect_equal("query plan problems" "${problems}" 0)
string(JSON entries LENGTH "${json}" routes)
list(LENGTH routes route_count)
math(EXPR want_entries "2 * ${route_count}")
expect_equal("route figures" "${entries}" "${want_entries}")
math(EXPR last "${entries} - 1")
set(seen "")
foreach(i RANGE ${last})
  string(JSON route GET "${json}" routes ${i} route)
  string(JSON clients GET "${json}" routes ${i} clients)
  string(JSON count GET "${json}" routes ${i} count)
  string(JSON errors GET "${json}" routes ${i} errors)
  string(JSON p99 GET "${json}" routes ${i} p99_ms)
  expect_equal("${route} with ${clients} clients: errors" "${errors}" 0)
  if(NOT count GREATER 0 OR NOT p99 MATCHES "^[0-9]+(\\.[0-9]+)?(e[-+]?[0-9]+)?$")
    remove_db()
    message(FATAL_ERROR "${route} with ${clients} clients: count ${count}, p99 ${p99}")
  endif()
  list(APPEND seen "${route} x${clients}")
endforeach()
foreach(route IN LISTS routes)
  foreach(clients 1 8)
    if(NOT "${route} x${clients}" IN_LIST seen)
      remove_db()
      message(FATAL_ERROR "no figures for ${route} with ${clients} clients")
    endif()
  endforeach()
endforeach()

# 2. The table, over the database kept by the first run.
run_bench(text --requests 5 --seconds 60 --db "${db}" --reuse)
remove_db()
if(NOT text MATCHES "reused as found")
  message(FATAL_ERROR "--reuse filled the database again:\n${text}")
endif()
foreach(route IN LISTS routes)
  string(REGEX REPLACE "([][+.*()^$?{}|\\\\])" "\\\\\\1" pattern "${route}")
  foreach(clients 1 8)
    if(NOT text MATCHES "\n${pattern} +${clients} +[1-9][0-9]* +[0-9]+\\.[0-9]+ ")
      message(FATAL_ERROR "no table line for ${route} with ${clients} clients:\n${text}")
    endif()
  endforeach()
endforeach()
if(NOT text MATCHES "query plans: ok")
  message(FATAL_ERROR "query plans not ok:\n${text}")
endif()
