pg_add_bench(bench_calib SOURCES bench_calib.cpp DEPS pg_calib)
