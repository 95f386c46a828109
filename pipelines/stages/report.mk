# `make report`: the shot report. Gathers every run report of WORK/reports into WORK/shot-report.json
# and writes WORK/shot-report.md: time per job, the evaluations, links to the pictures. REPORT_DEPS:
# the recipe's final outputs (the report is remade when they change).
SHOT_REPORT = $(WORK)/shot-report.md

$(SHOT_REPORT) $(WORK)/shot-report.json &: $(REPORT_DEPS) $(PIPELINES)/scripts/shot-report.sh
	sh $(PIPELINES)/scripts/shot-report.sh $(WORK)

report: $(SHOT_REPORT)
	@cat $(SHOT_REPORT)
.PHONY: report
