# Scenario 3: a panorama pair -> pg-sphdepth, merged with a scan and with perspective depth maps of
# one area -> pg-refine of that area.
#
#   make -f pipelines/scenario3.mk WORK=shot PANO_CAMERAS=pano/cameras.json SCANS=lidar.ply@2 \
#        AREA_DEPTH="$(ls area/depth/*.exr)" REFINE_CAMERAS=area/cameras.json MERGE_VOXEL=0.02
#
# Inputs
#   PANO_CAMERAS    cameras file holding the two panoramas as a rig (pg-sphdepth --cameras)
#   PANO_STEM       name of the range map (default: pano)
#   SCANS           range scans (PLY/OBJ meshes, or range EXRs such as a LIDAR's), FILE@W weighs one
#   SCAN_FLAGS      e.g. --sensor-origin X,Y,Z for mesh and point-cloud scans without their own origins
#   AREA_DEPTH      perspective depth maps of the area (e.g. scenario2.mk's WORK/depth/*.exr)
#   REFINE_CAMERAS  cameras the refinement compares (the area's photos; default PANO_CAMERAS)
#   REFINE_WORKING_SET / REFINE_PINNED  vertex masks of the merged mesh, optional
#   TRUTH_MESH      optional; MERGE_VOXEL, SPHDEPTH_FLAGS, MERGE_VOLUME_FLAGS, REFINE_*, REMESH_*
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk
PANO_STEM ?= pano
SCANS ?=
SCAN_FLAGS ?=
AREA_DEPTH ?=
SPHDEPTH_FLAGS ?=
MERGE_VOLUME_FLAGS ?= --min-piece 0.05
REFINE_CAMERAS ?= $(PANO_CAMERAS)
TRUTH_MESH ?=
.DEFAULT_GOAL := all
all: scenario3
.PHONY: all scenario3

SPH_DIR = $(WORK)/sphdepth
PANO_RANGE = $(SPH_DIR)/$(PANO_STEM).exr
$(PANO_RANGE) $(SPH_DIR)/$(PANO_STEM)-mesh.ply $(SPH_DIR)/$(PANO_STEM)-range.png &: $(PANO_CAMERAS) | $(SPH_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-sphdepth --cameras $(PANO_CAMERAS) --out-dir $(SPH_DIR) --stem $(PANO_STEM) \
	  $(SPHDEPTH_FLAGS) $(PG_FLAGS) $(call pg_report,sphdepth)

# One volume over every source: the panorama ranges, the scans and the area's depth maps.
MERGE_DIR = $(WORK)/merge
MERGED_MESH = $(MERGE_DIR)/merged.ply
scan_files = $(foreach f,$(1),$(firstword $(subst @, ,$(f))))
range_scans = $(foreach f,$(SCANS),$(if $(filter %.exr,$(firstword $(subst @, ,$(f)))),$(f)))
mesh_scans = $(filter-out $(range_scans),$(SCANS))
$(MERGED_MESH) $(MERGE_DIR)/merged.vdb &: $(PANO_RANGE) $(call scan_files,$(SCANS)) $(AREA_DEPTH) | $(MERGE_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-merge volume --depth $(PANO_RANGE) $(range_scans) $(AREA_DEPTH) \
	  $(if $(mesh_scans),--scan $(mesh_scans) $(SCAN_FLAGS)) --voxel-size $(MERGE_VOXEL) \
	  --out $(MERGED_MESH) --vdb $(MERGE_DIR)/merged.vdb $(MERGE_VOLUME_FLAGS) $(PG_FLAGS) $(call pg_report,merge)

REFINE_MESH_IN = $(MERGED_MESH)
REFINE_MESH_ACCURACY ?= $(MERGE_VOXEL)
REFINE_DIR = $(WORK)/refine
include $(PIPELINES)/stages/refine.mk

EVAL_MESHES = $(if $(TRUTH_MESH),panorama=$(SPH_DIR)/$(PANO_STEM)-mesh.ply merged=$(MERGED_MESH) refined=$(REFINED_MESH))
include $(PIPELINES)/stages/eval.mk

REPORT_DEPS = $(REFINED_MESH) $(EVAL_MESH_RESULTS)
include $(PIPELINES)/stages/report.mk
scenario3: $(SHOT_REPORT)
