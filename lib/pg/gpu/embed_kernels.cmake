# Writes OUTPUT, a header with one raw string constant per kernel file in KERNELS:
# kernels/flow_increments.cl becomes pg::gpu::kernels::flow_increments. KERNELS is "|"-separated.
string(REPLACE "|" ";" KERNELS "${KERNELS}")
set(text "// Generated from lib/pg/gpu/kernels/*.cl by embed_kernels.cmake; do not edit.\n#pragma once\n\nnamespace pg::gpu::kernels {\n")
foreach(kernel IN LISTS KERNELS)
  get_filename_component(name ${kernel} NAME_WE)
  file(READ ${kernel} source)
  string(APPEND text "inline constexpr const char* ${name} = R\"pgcl(${source})pgcl\";\n")
endforeach()
string(APPEND text "}  // namespace pg::gpu::kernels\n")
file(WRITE ${OUTPUT}.tmp "${text}")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
file(REMOVE ${OUTPUT}.tmp)
