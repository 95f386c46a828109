# Scenario 1 on the built-in "deform" scene: a rock whose modelled mesh (initial.ply) misses a known
# low-frequency deformation; refinement should bring it to the true mesh.
#   make -f pipelines/synth-scenario1.mk WORK=s1 PG_BIN=build/bin -j 2
WORK ?= synth-scenario1
SYNTH_WIDTH ?= 320
SYNTH_HEIGHT ?= 240
DEFORM_VIEWS ?= 12
EVAL_THRESHOLDS ?= 0.005,0.01,0.02
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk
include $(PIPELINES)/stages/synth.mk
DEFORM_DIR = $(WORK)/synth
$(eval $(call pg_synth_rule,deform,$(DEFORM_DIR),$(call pg_view_ids,$(DEFORM_VIEWS)),,initial.ply))
MODEL_MESH = $(DEFORM_DIR)/initial.ply
CAMERAS = $(DEFORM_DIR)/cameras.json
TRUTH_MESH = $(DEFORM_DIR)/mesh.ply
include $(PIPELINES)/scenario1.mk
