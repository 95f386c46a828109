# pg-refine run: the mesh moves until it agrees with the photos; the caches feed the details brush.
# Inputs: REFINE_MESH_IN, REFINE_CAMERAS, REFINE_DIR, REFINE_WORKING_SET / REFINE_PINNED (vertex
# masks of REFINE_MESH_IN, optional), REFINE_ITERATIONS, REFINE_FLAGS, REFINE_MESH_ACCURACY (expected
# error of REFINE_MESH_IN, scene units; recipes refining a merged mesh default it to MERGE_VOXEL so
# a pair that resolves depth worse than the merge cannot make it worse). Output: REFINED_MESH.
REFINE_ITERATIONS ?= 4
REFINE_WORKING_SET ?=
REFINE_PINNED ?=
REFINE_FLAGS ?=
REFINE_MESH_ACCURACY ?=
REFINED_MESH = $(REFINE_DIR)/refined.ply
REFINE_CACHES = $(REFINE_DIR)/pre.ply $(REFINE_DIR)/post.ply

$(REFINED_MESH) $(REFINE_CACHES) &: $(REFINE_MESH_IN) $(REFINE_CAMERAS) $(REFINE_WORKING_SET) $(REFINE_PINNED) | $(REFINE_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-refine run --mesh $(REFINE_MESH_IN) --cameras $(REFINE_CAMERAS) --out $(REFINED_MESH) \
	  --iterations $(REFINE_ITERATIONS) --pre-cache $(REFINE_DIR)/pre.ply --post-cache $(REFINE_DIR)/post.ply \
	  $(if $(REFINE_WORKING_SET),--working-set $(REFINE_WORKING_SET)) $(if $(REFINE_PINNED),--pinned $(REFINE_PINNED)) \
	  $(if $(REFINE_MESH_ACCURACY),--mesh-accuracy $(REFINE_MESH_ACCURACY)) $(REFINE_FLAGS) $(PG_FLAGS) $(call pg_report,refine)
