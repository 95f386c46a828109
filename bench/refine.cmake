pg_add_bench(bench_refine SOURCES bench_refine.cpp DEPS pg_refine pg_synth pg_gpu)
