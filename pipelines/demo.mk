# The demo: every stage that exists, on the built-in "set" scene.
# make -f pipelines/demo.mk OUT=demo-out PG_BIN=build/bin
OUT ?= demo-out
PG_BIN ?= build/bin
SEED ?= 1
COMMON = --seed $(SEED) --progress lines

all: $(OUT)/report.json

$(OUT)/synth/cameras.json:
	mkdir -p $(OUT)/synth
	$(PG_BIN)/pg-synth set --out $(OUT)/synth $(COMMON) --report $(OUT)/synth.report.json

$(OUT)/eval-self.json: $(OUT)/synth/cameras.json
	$(PG_BIN)/pg-eval cameras --estimate $(OUT)/synth/cameras.json --truth $(OUT)/synth/cameras.json \
	  --out $@ $(COMMON) --report $(OUT)/eval.report.json

$(OUT)/report.json: $(OUT)/eval-self.json
	@echo "[" > $@.tmp; first=1; for r in $(OUT)/*.report.json; do \
	  if [ $$first = 0 ]; then echo "," >> $@.tmp; fi; cat $$r >> $@.tmp; first=0; done; echo "]" >> $@.tmp
	@mv $@.tmp $@

.PHONY: all
