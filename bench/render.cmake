pg_add_bench(bench_render SOURCES bench_render.cpp DEPS pg_render ${OpenCV_LIBS})
