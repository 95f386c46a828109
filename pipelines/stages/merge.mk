# pg-merge: partial TSDF integrations of MERGE_CHUNK inputs each (one farm job each), then one
# combine. Inputs: MERGE_INPUTS (depth EXRs, FILE@W weighs one), MERGE_DIR, MERGE_VOXEL,
# MERGE_MASKS (folder of masks, optional), MERGE_INTEGRATE_FLAGS, MERGE_COMBINE_FLAGS.
# Outputs: MERGED_MESH (MERGE_DIR/merged.ply) and MERGE_DIR/merged.vdb (opens in Houdini).
MERGE_CHUNK ?= 4
MERGE_MASKS ?=
MERGE_INTEGRATE_FLAGS ?=
MERGE_COMBINE_FLAGS ?= --min-piece 0.05
MERGED_MESH = $(MERGE_DIR)/merged.ply
MERGE_STARTS = $(call pg_chunk_starts,$(MERGE_INPUTS),$(MERGE_CHUNK))
MERGE_PARTIALS = $(foreach s,$(MERGE_STARTS),$(MERGE_DIR)/part-$(s).vdb)

# Each partial names only its own inputs, so a changed depth map redoes one partial (the farm form
# with the whole list and --range-start/--range-size is in pipelines/README.md).
define merge_partial_rule
$(MERGE_DIR)/part-$(1).vdb: $(foreach f,$(call pg_chunk,$(MERGE_INPUTS),$(1),$(MERGE_CHUNK)),$(firstword $(subst @, ,$(f)))) | $(MERGE_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-merge integrate --depth $(call pg_chunk,$(MERGE_INPUTS),$(1),$(MERGE_CHUNK)) \
	  --voxel-size $(MERGE_VOXEL) $(if $(MERGE_MASKS),--masks $(MERGE_MASKS)) $(MERGE_INTEGRATE_FLAGS) \
	  --vdb $$@ $(PG_FLAGS) $(call pg_report,merge-part-$(1))
endef
$(foreach s,$(MERGE_STARTS),$(eval $(call merge_partial_rule,$(s))))

$(MERGED_MESH) $(MERGE_DIR)/merged.vdb &: $(MERGE_PARTIALS)
	$(PG_BIN)/pg-merge combine --partials $(MERGE_PARTIALS) --out $(MERGED_MESH) --vdb $(MERGE_DIR)/merged.vdb \
	  $(MERGE_COMBINE_FLAGS) $(PG_FLAGS) $(call pg_report,merge-combine)
