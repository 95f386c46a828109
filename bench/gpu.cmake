pg_add_bench(bench_gpu SOURCES bench_gpu.cpp DEPS pg_gpu pg_flow pg_fusion)
