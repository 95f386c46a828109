# pg-eval mesh: each mesh of EVAL_MESHES (NAME=PATH words) against TRUTH_MESH, written to
# WORK/eval/mesh-NAME.json. EVAL_THRESHOLDS: distances for precision / recall / F-score.
EVAL_THRESHOLDS ?= 0.01,0.02,0.05
EVAL_SAMPLES ?= 50000
EVAL_MESH_RESULTS = $(foreach m,$(EVAL_MESHES),$(WORK)/eval/mesh-$(firstword $(subst =, ,$(m))).json)

define eval_mesh_rule
$(WORK)/eval/mesh-$(1).json: $(2) $(TRUTH_MESH) | $(WORK)/eval/ $(REPORTS)/
	$(PG_BIN)/pg-eval mesh --estimate $(2) --truth $(TRUTH_MESH) --out $$@ --samples $(EVAL_SAMPLES) \
	  --thresholds $(EVAL_THRESHOLDS) $(PG_FLAGS) $(call pg_report,eval-mesh-$(1))
endef
$(foreach m,$(EVAL_MESHES),$(eval $(call eval_mesh_rule,$(firstword $(subst =, ,$(m))),$(lastword $(subst =, ,$(m))))))
