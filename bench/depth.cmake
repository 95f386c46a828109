# Flow and depth benchmarks: our variational flow against OpenCV's dense methods (DIS with
# VariationalRefinement, DeepFlow, DualTVL1, Farneback from opencv_optflow / video) and StereoSGBM on
# MPI-Sintel and Middlebury, the speed ratio on a 1536x1024 pair, and depth accuracy on synthetic scenes.
if(TARGET pg_flow AND TARGET pg_sfm)
  pg_add_bench(bench_flow SOURCES bench_flow.cpp DEPS pg_flow pg_eval pg_image pg_sfm opencv_optflow ${OpenCV_LIBS})
endif()
if(TARGET pg_depth)
  pg_add_bench(bench_depth SOURCES bench_depth.cpp DEPS pg_depth pg_eval)
endif()
