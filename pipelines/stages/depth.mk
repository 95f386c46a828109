# pg-depth on neighbouring pairs, in farm chunks of DEPTH_CHUNK pairs (one job each, `--range`).
# Inputs: DEPTH_CAMERAS, DEPTH_IDS (camera ids in sequence order), DEPTH_DIR, DEPTH_CLOSE_RING (1:
# also pair the last view with the first), DEPTH_MASKS (folder, optional), DEPTH_SCALE, DEPTH_FLAGS.
# Output: DEPTH_MAPS (DEPTH_DIR/REF-OTHER.exr) and their previews.
DEPTH_CHUNK ?= 1
DEPTH_SCALE ?= 1
DEPTH_CLOSE_RING ?=
DEPTH_MASKS ?=
DEPTH_FLAGS ?= --preview
DEPTH_PAIRS = $(call pg_consecutive_pairs,$(DEPTH_IDS)) \
              $(if $(DEPTH_CLOSE_RING),$(lastword $(DEPTH_IDS)):$(firstword $(DEPTH_IDS)))
depth_map_of = $(DEPTH_DIR)/$(subst :,-,$(1)).exr
DEPTH_MAPS = $(foreach p,$(DEPTH_PAIRS),$(call depth_map_of,$(p)))

# One rule per chunk; the whole pair list is on every command line, --range picks the chunk.
define depth_chunk_rule
$(foreach p,$(call pg_chunk,$(DEPTH_PAIRS),$(1),$(DEPTH_CHUNK)),$(call depth_map_of,$(p))) &: $(DEPTH_CAMERAS) $(if $(DEPTH_MASKS),$(wildcard $(DEPTH_MASKS)/*.png)) | $(DEPTH_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-depth --cameras $(DEPTH_CAMERAS) --out-dir $(DEPTH_DIR) --pair $(DEPTH_PAIRS) \
	  --range $(1),$(DEPTH_CHUNK) --scale $(DEPTH_SCALE) $(if $(DEPTH_MASKS),--masks $(DEPTH_MASKS)) \
	  $(DEPTH_FLAGS) $(PG_FLAGS) $(call pg_report,depth-$(1))
endef
$(foreach s,$(call pg_chunk_starts,$(DEPTH_PAIRS),$(DEPTH_CHUNK)),$(eval $(call depth_chunk_rule,$(s))))
