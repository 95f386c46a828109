pg_add_bench(bench_render_gpu SOURCES bench_render_gpu.cpp DEPS pg_gpu pg_render)
