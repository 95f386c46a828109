# Scenario 1, refine only: a modelled mesh + photos + cameras -> pg-refine (working set, pins) ->
# pg-remesh, with evaluations where a true surface is given.
#
#   make -f pipelines/scenario1.mk WORK=shot MODEL_MESH=set.obj CAMERAS=plates/cameras.json \
#        REFINE_WORKING_SET=face.pgmask.json REFINE_PINNED=rim.pgmask.json -j 2
#
# Inputs: WORK, MODEL_MESH, CAMERAS (pg-cameras; images found through it), REFINE_WORKING_SET and
# REFINE_PINNED (vertex masks of MODEL_MESH, optional), TRUTH_MESH (optional), REFINE_* / REMESH_*.
include $(dir $(lastword $(MAKEFILE_LIST)))stages/common.mk
TRUTH_MESH ?=
.DEFAULT_GOAL := all
all: scenario1
.PHONY: all scenario1

REFINE_MESH_IN = $(MODEL_MESH)
REFINE_CAMERAS = $(CAMERAS)
REFINE_DIR = $(WORK)/refine
include $(PIPELINES)/stages/refine.mk

REMESH_IN = $(REFINED_MESH)
REMESH_BEFORE = $(MODEL_MESH)
REMESH_DIR = $(WORK)/remesh
REMESH_PINNED = $(REFINE_PINNED)
include $(PIPELINES)/stages/remesh.mk

EVAL_MESHES = $(if $(TRUTH_MESH),model=$(MODEL_MESH) refined=$(REFINED_MESH) remeshed=$(REMESHED_MESH))
include $(PIPELINES)/stages/eval.mk

REPORT_DEPS = $(REMESHED_MESH) $(EVAL_MESH_RESULTS)
include $(PIPELINES)/stages/report.mk
scenario1: $(SHOT_REPORT)
