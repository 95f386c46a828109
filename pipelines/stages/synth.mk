# pg-synth: a built-in scene with exact ground truth.
# $(eval $(call pg_synth_rule,SCENE,DIR,VIEW_IDS,FLAGS,EXTRA_FILES)) renders SCENE into DIR; every image of
# VIEW_IDS and every EXTRA_FILE (e.g. initial.ply, depth/pano_upper.exr) is an explicit target. SYNTH_WIDTH, SYNTH_HEIGHT, SYNTH_SUPERSAMPLE size the images.
SYNTH_WIDTH ?= 640
SYNTH_HEIGHT ?= 480
SYNTH_SUPERSAMPLE ?= 2
# view_000 ... for N views, as pg-synth names them: $(call pg_view_ids,N).
pg_view_ids = $(shell seq -f 'view_%03g' 0 $$(($(1) - 1)))
pg_synth_images = $(foreach id,$(2),$(1)/images/$(id).png)

define pg_synth_rule
$(2)/cameras.json $(2)/mesh.ply $(2)/scene.json $(call pg_synth_images,$(2),$(3)) $(addprefix $(2)/,$(5)) &: | $(REPORTS)/
	$(PG_BIN)/pg-synth $(1) --out $(2) --width $(SYNTH_WIDTH) --height $(SYNTH_HEIGHT) --views $(words $(3)) \
	  --supersample $(SYNTH_SUPERSAMPLE) $(4) $(PG_FLAGS) $(call pg_report,synth-$(1))
endef
