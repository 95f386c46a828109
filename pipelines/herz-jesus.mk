# Scenario 2 on real photos: Strecha et al. Herz-Jesus-P8 (8 views, 3072x2048, in $(PG_DATA_DIR)).
# The published cameras give the camera error of pg-track and the frame and units of the mesh.
#   make -f pipelines/herz-jesus.mk WORK=hj PG_BIN=build/bin -j 2
WORK ?= herz-jesus
PG_DATA_DIR ?= ../shared/data
HJ_DIR = $(PG_DATA_DIR)/multiview/strecha/Herz-Jesus-P8
TRACK_FLAGS ?= --downscale 2
DEPTH_SCALE ?= 0.25
DEPTH_CHUNK ?= 1
MERGE_VOXEL ?= 0.03
MERGE_CHUNK ?= 4
REFINE_FLAGS ?= --scale 0.25
REFINE_ITERATIONS ?= 2
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk

SHOT_IMAGES := $(sort $(wildcard $(HJ_DIR)/images/*.jpg))
HJ_TRUTH_FILES := $(sort $(wildcard $(HJ_DIR)/gt_dense_cameras/*.camera))
TRUTH_CAMERAS = $(WORK)/truth/cameras.json
$(TRUTH_CAMERAS): $(HJ_TRUTH_FILES) $(PIPELINES)/scripts/strecha-cameras.awk | $(WORK)/truth/
	awk -v images=$(abspath $(HJ_DIR)/images) -v now=$$(date -u +%Y-%m-%dT%H:%M:%SZ) \
	  -f $(PIPELINES)/scripts/strecha-cameras.awk $(HJ_TRUTH_FILES) > $@.tmp && mv $@.tmp $@

include $(PIPELINES)/scenario2.mk
