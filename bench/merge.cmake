# pg-merge's TSDF against Open3D's ScalableTSDFVolume (Debian python3-open3d, run by
# bench_merge_open3d.py) on the Kinect frames and on RGB-D frames rendered from the Stanford bunny.
if(TARGET pg_fusion AND TARGET pg_eval)
  pg_add_bench(bench_merge SOURCES bench_merge.cpp DEPS pg_fusion pg_eval)
  target_compile_definitions(bench_merge PRIVATE PG_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()
