# pg-calib calibrate: lens intrinsics from checkerboard photos. Inputs: CALIB_IMAGES (files),
# CALIB_BOARD (COLSxROWS inner corners), CALIB_SQUARE (metres), CALIB_OUT (cameras JSON),
# CALIB_FLAGS. Writes CALIB_OUT, its .calibration.json report and the coverage/distortion PNGs.
CALIB_BOARD ?= 9x6
CALIB_SQUARE ?= 0.025
CALIB_FLAGS ?=
CALIB_REPORT = $(CALIB_OUT:.json=.calibration.json)

$(CALIB_OUT) $(CALIB_REPORT) &: $(CALIB_IMAGES) | $(dir $(CALIB_OUT)) $(REPORTS)/
	$(PG_BIN)/pg-calib calibrate --images $(CALIB_IMAGES) --board $(CALIB_BOARD) --square $(CALIB_SQUARE) \
	  --out $(CALIB_OUT) $(CALIB_FLAGS) $(PG_FLAGS) $(call pg_report,calib)
