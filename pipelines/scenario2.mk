# Scenario 2: photos -> pg-calib -> pg-track -> pg-depth on neighbouring pairs -> pg-merge (masked)
# -> pg-refine (on a chosen region) -> pg-remesh, with evaluations where a truth is given.
# A recipe (demo.mk, herz-jesus.mk) sets the inputs and includes this file; or set them on the
# command line:
#
#   make -f pipelines/scenario2.mk WORK=shot SHOT_IMAGES="$(ls plates/*.png)" MERGE_VOXEL=0.02 -j 8
#
# Inputs
#   WORK            output folder (every file of the run lands under it)
#   SHOT_IMAGES     the photos, in sequence order (neighbours in the list overlap)
#   SHOT_IDS        their camera ids (default: the file stems, as pg-track names them)
#   CALIB_IMAGES    checkerboard photos (optional): calibrated into WORK/calib/lens.json
#   LENS_FROM_CALIB 1 (default): track with the calibrated lens fixed; empty: pg-track self-calibrates
#                   (when the board was shot through another lens, the calibration is only reported)
#   TRUTH_CAMERAS   true or surveyed cameras (optional): the tracked cameras are evaluated and
#                   moved into their frame and units
#   TRUTH_MESH      true surface (optional): every mesh is evaluated against it
#   MERGE_MASKS     folder of masks <camera id>.png / <depth stem>.png, nonzero = ignore (optional)
#   REFINE_WORKING_SET, REFINE_PINNED  vertex masks of the merged mesh (optional; a chosen region)
#   and every stage variable of stages/*.mk (DEPTH_SCALE, DEPTH_CHUNK, MERGE_VOXEL, MERGE_CHUNK, ...).
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk

SHOT_IDS ?= $(basename $(notdir $(SHOT_IMAGES)))
CALIB_IMAGES ?=
LENS_FROM_CALIB ?= 1
TRUTH_CAMERAS ?=
TRUTH_MESH ?=

.DEFAULT_GOAL := all
all: scenario2
.PHONY: all scenario2

CALIB_OUT = $(WORK)/calib/lens.json
ifneq ($(CALIB_IMAGES),)
include $(PIPELINES)/stages/calib.mk
endif

TRACK_IMAGES = $(SHOT_IMAGES)
TRACK_DIR = $(WORK)/track
TRACK_INTRINSICS = $(if $(and $(CALIB_IMAGES),$(LENS_FROM_CALIB)),$(CALIB_OUT))
TRACK_TRUTH = $(TRUTH_CAMERAS)
include $(PIPELINES)/stages/track.mk

DEPTH_CAMERAS = $(TRACK_CAMERAS)
DEPTH_IDS = $(SHOT_IDS)
DEPTH_DIR = $(WORK)/depth
include $(PIPELINES)/stages/depth.mk

MERGE_INPUTS = $(DEPTH_MAPS)
MERGE_DIR = $(WORK)/merge
include $(PIPELINES)/stages/merge.mk

REFINE_MESH_IN = $(MERGED_MESH)
REFINE_MESH_ACCURACY ?= $(MERGE_VOXEL)
REFINE_CAMERAS = $(TRACK_CAMERAS)
REFINE_DIR = $(WORK)/refine
include $(PIPELINES)/stages/refine.mk

REMESH_IN = $(REFINED_MESH)
REMESH_BEFORE = $(MERGED_MESH)
REMESH_DIR = $(WORK)/remesh
include $(PIPELINES)/stages/remesh.mk

EVAL_MESHES = $(if $(TRUTH_MESH),merged=$(MERGED_MESH) refined=$(REFINED_MESH) remeshed=$(REMESHED_MESH))
include $(PIPELINES)/stages/eval.mk

REPORT_DEPS = $(REMESHED_MESH) $(EVAL_MESH_RESULTS) $(if $(TRUTH_CAMERAS),$(TRACK_EVAL)) \
              $(if $(CALIB_IMAGES),$(CALIB_OUT))
include $(PIPELINES)/stages/report.mk

scenario2: $(SHOT_REPORT)
