# The proof-of-play history: a visit's insert (with its proof image) and the month's summary,
# over simulated 8-hour days of missions/all_day.yaml (tests/bench/bench_history.cpp).
find_package(SQLite3 REQUIRED)
projtour_add_bench(bench_history SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_history.cpp
  LIBS SQLite::SQLite3)
# BM_MonthSummaryCommand runs the command itself.
add_dependencies(bench_history projtour)
