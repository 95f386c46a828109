pg_add_bench(bench_track SOURCES bench_track.cpp DEPS pg_sfm pg_eval)
