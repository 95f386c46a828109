# pg-track: cameras of an ordered image sequence. Inputs: TRACK_IMAGES (files, in sequence order),
# TRACK_DIR, TRACK_INTRINSICS (optional cameras file from pg-calib or a lens database: used fixed),
# TRACK_FLAGS. Image paths are made absolute so the cameras file finds them from any folder.
#
# With TRACK_TRUTH (true or surveyed cameras) the tracked cameras are evaluated against it and moved
# into its frame (the least-squares similarity of the camera centres), so later stages and the mesh
# evaluation work in the truth's units; without it the cameras stay in pg-track's own frame.
TRACK_FLAGS ?=
TRACK_INTRINSICS ?=
TRACK_TRUTH ?=
TRACK_OUTPUTS = $(addprefix $(TRACK_DIR)/,cameras.json points.ply tracks.json top_view.png)
TRACK_CAMERAS = $(if $(TRACK_TRUTH),$(TRACK_DIR)/cameras-aligned.json,$(TRACK_DIR)/cameras.json)
TRACK_EVAL = $(WORK)/eval/cameras.json

$(TRACK_OUTPUTS) &: $(TRACK_IMAGES) $(TRACK_INTRINSICS) | $(TRACK_DIR)/ $(REPORTS)/
	$(PG_BIN)/pg-track --images $(TRACK_IMAGES) --out $(TRACK_DIR) \
	  $(if $(TRACK_INTRINSICS),--cameras $(TRACK_INTRINSICS) --intrinsics fixed) $(TRACK_FLAGS) \
	  $(PG_FLAGS) $(call pg_report,track)

$(TRACK_EVAL): $(TRACK_DIR)/cameras.json $(TRACK_TRUTH) | $(WORK)/eval/ $(REPORTS)/
	$(PG_BIN)/pg-eval cameras --estimate $< --truth $(TRACK_TRUTH) --out $@ $(PG_FLAGS) $(call pg_report,eval-cameras)

# Beside the tracked cameras: their image paths stay valid.
$(TRACK_DIR)/cameras-aligned.json: $(TRACK_EVAL) $(TRACK_DIR)/cameras.json $(PIPELINES)/scripts/align-cameras.awk
	awk -f $(PIPELINES)/scripts/align-cameras.awk $(TRACK_EVAL) $(TRACK_DIR)/cameras.json > $@.tmp && mv $@.tmp $@
