# pg-remesh against CGAL's isotropic_remeshing (Polygon Mesh Processing) on the Stanford bunny: the
# same target length, iterations and feature angle, timings and the same quality numbers for both.
# CGAL is header-only (Debian: libcgal-dev) and used here only; without it the benchmark is skipped.
if(TARGET pg_remesh)
  find_package(CGAL QUIET)
  if(CGAL_FOUND)
    pg_add_bench(bench_remesh SOURCES bench_remesh.cpp DEPS pg_remesh CGAL::CGAL)
  else()
    message(STATUS "pg: CGAL not found (Debian package libcgal-dev); bench_remesh is not built")
  endif()
endif()
