# Smoke test of tally_bench_wake with tiny numbers, on a temporary SQLite
# file: each round must time every post and print its line. Timings are
# never looked at.
# Run as: cmake -DBENCH=<tally_bench_wake> -P wake_smoke.cmake
cmake_minimum_required(VERSION 3.25)
execute_process(COMMAND "${BENCH}" --workers 1,3 --posts 5 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tally_bench_wake exited with ${rc}\n${out}\n${err}")
endif()
foreach(workers 1 3)
  if(NOT out MATCHES "\n +${workers} +5 +[0-9]+\\.[0-9]+ +[0-9]+\\.[0-9]+ +[0-9]+\\.[0-9]+ +[0-9]+\\.[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+\n")
    message(FATAL_ERROR "no line for ${workers} worker(s) with 5 posts timed:\n${out}")
  endif()
endforeach()
