# Scenario 3 on the built-in "room": two panoramas 27 cm apart; the true range map of the upper
# head stands in for a LIDAR scan taken from there (weight 2).
#   make -f pipelines/synth-scenario3.mk WORK=s3 PG_BIN=build/bin -j 2
WORK ?= synth-scenario3
SYNTH_HEIGHT ?= 256
MERGE_VOXEL ?= 0.05
REFINE_ITERATIONS ?= 2
# Two views only: name the pair (the automatic choice looks for perspective baselines).
REFINE_FLAGS ?= --pairs pano_lower:pano_upper
EVAL_THRESHOLDS ?= 0.02,0.05,0.1
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk
include $(PIPELINES)/stages/synth.mk
ROOM_DIR = $(WORK)/synth
$(eval $(call pg_synth_rule,room,$(ROOM_DIR),pano_lower pano_upper,,depth/pano_upper.exr))
PANO_CAMERAS = $(ROOM_DIR)/cameras.json
SCANS = $(ROOM_DIR)/depth/pano_upper.exr@2
TRUTH_MESH = $(ROOM_DIR)/mesh.ply
include $(PIPELINES)/scenario3.mk
