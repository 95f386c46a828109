# pg-remesh: isotropic remeshing of what refinement moved (REMESH_GROW rings around it), pinned
# vertices kept. Inputs: REMESH_IN, REMESH_BEFORE (same topology, before refinement), REMESH_DIR,
# REMESH_PINNED (optional mask), REMESH_FLAGS. Outputs: REMESHED_MESH, its quality report and histogram.
REMESH_GROW ?= 2
REMESH_PINNED ?=
REMESH_FLAGS ?=
REMESHED_MESH = $(REMESH_DIR)/remeshed.ply

$(REMESHED_MESH) $(REMESH_DIR)/remesh-quality.json $(REMESH_DIR)/remesh-histogram.png &: $(REMESH_IN) $(REMESH_BEFORE) $(REMESH_PINNED) | $(REMESH_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-remesh --in $(REMESH_IN) --out $(REMESHED_MESH) --deformed-from $(REMESH_BEFORE) \
	  --grow $(REMESH_GROW) $(if $(REMESH_PINNED),--pinned $(REMESH_PINNED)) \
	  --quality-report $(REMESH_DIR)/remesh-quality.json --histogram $(REMESH_DIR)/remesh-histogram.png \
	  $(REMESH_FLAGS) $(PG_FLAGS) $(call pg_report,remesh)
