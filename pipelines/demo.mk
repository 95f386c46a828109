# The demo: scenario 2 end to end on the built-in synthetic set, with the accuracy of the final mesh
# against the scene's true mesh and the time of every job; and the panorama pair: the synthetic room
# seen by two equirectangular panoramas 27 cm apart, ranged by pg-sphdepth and scored against the
# true range map.
#
#   make -f pipelines/demo.mk WORK=demo-out PG_BIN=build/bin -j 2      (scripts/demo.sh runs this)
#
# The board is rendered through a distorted lens that the set was not shot with, so its calibration
# is reported (WORK/reports/calib.report.json) and pg-track self-calibrates the set's lens. Sizes are
# variables: DEMO_VIEWS, SYNTH_WIDTH, SYNTH_HEIGHT, BOARD_VIEWS, DEPTH_SCALE, MERGE_VOXEL, PANO_HEIGHT.
WORK ?= demo-out
DEMO_VIEWS ?= 32
BOARD_VIEWS ?= 15
SYNTH_WIDTH ?= 640
SYNTH_HEIGHT ?= 480
DEPTH_SCALE ?= 0.5
DEPTH_CLOSE_RING ?= 1
DEPTH_CHUNK ?= 4
MERGE_VOXEL ?= 0.03
MERGE_CHUNK ?= 8
REFINE_ITERATIONS ?= 3
EVAL_THRESHOLDS ?= 0.02,0.05,0.1
PANO_HEIGHT ?= 256

include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk
include $(PIPELINES)/stages/synth.mk

SET_DIR = $(WORK)/synth
BOARD_DIR = $(WORK)/board
SHOT_IDS := $(call pg_view_ids,$(DEMO_VIEWS))
SHOT_IMAGES := $(call pg_synth_images,$(SET_DIR),$(SHOT_IDS))
CALIB_IMAGES := $(call pg_synth_images,$(BOARD_DIR),$(call pg_view_ids,$(BOARD_VIEWS)))
LENS_FROM_CALIB =
TRUTH_CAMERAS = $(SET_DIR)/cameras.json
TRUTH_MESH = $(SET_DIR)/mesh.ply
$(eval $(call pg_synth_rule,set,$(SET_DIR),$(SHOT_IDS)))
$(eval $(call pg_synth_rule,checkerboard,$(BOARD_DIR),$(call pg_view_ids,$(BOARD_VIEWS))))

include $(PIPELINES)/scenario2.mk

# The panorama pair: the room's two panoramas -> range map, mesh and preview -> its accuracy.
ROOM_DIR = $(WORK)/room
PANO_DIR = $(WORK)/panorama
$(ROOM_DIR)/cameras.json $(ROOM_DIR)/depth/pano_lower.exr &: | $(REPORTS)/
	$(PG_BIN)/pg-synth room --out $(ROOM_DIR) --height $(PANO_HEIGHT) --supersample $(SYNTH_SUPERSAMPLE) \
	  $(PG_FLAGS) $(call pg_report,synth-room)
$(PANO_DIR)/pano_lower.exr $(PANO_DIR)/pano_lower-mesh.ply $(PANO_DIR)/pano_lower-range.png &: \
    $(ROOM_DIR)/cameras.json | $(PANO_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-sphdepth --cameras $< --out-dir $(PANO_DIR) $(PG_FLAGS) $(call pg_report,sphdepth)
$(PANO_DIR)/eval.txt: $(PANO_DIR)/pano_lower.exr $(ROOM_DIR)/depth/pano_lower.exr
	$(PG_BIN)/pg-eval depth --estimate $< --truth $(ROOM_DIR)/depth/pano_lower.exr \
	  --out $(PANO_DIR)/eval.json $(PG_FLAGS) $(call pg_report,eval-panorama-range) > $@.tmp && mv $@.tmp $@
# The shot report gathers every run report: it waits for the panorama's.
$(SHOT_REPORT): $(PANO_DIR)/eval.txt

# Prints the final mesh's accuracy, the time of each job and the panorama pair's range accuracy.
demo: $(SHOT_REPORT) $(PANO_DIR)/eval.txt
	@echo "demo: final mesh $(REMESHED_MESH) against the true mesh $(TRUTH_MESH):"
	@sed -n '/^## eval-mesh-remeshed/,/^## /p' $(SHOT_REPORT) | grep '^- '
	@echo "demo: time per job (from the run reports):"
	@sed -n '/^| job/,/^Total/p' $(SHOT_REPORT)
	@echo "demo: panorama pair $(PANO_DIR) (range map, mesh with UVs, preview) against the true ranges:"
	@cat $(PANO_DIR)/eval.txt
.PHONY: demo
.DEFAULT_GOAL := demo
