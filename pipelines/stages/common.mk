# Shared settings of every recipe. A recipe sets WORK (its output folder) and includes this first.
# Every rule is one tool command line with explicit inputs and outputs, so `make -n` is a job list.
ifndef PG_COMMON_MK
PG_COMMON_MK := 1
PG_BIN ?= build/bin
SEED ?= 1
THREADS ?= 0
PROGRESS ?= lines
LOG_LEVEL ?= warn
# The flags of the shared CLI frame (tools/common/cli.h), given to every tool.
PG_FLAGS = --seed $(SEED) --threads $(THREADS) --progress $(PROGRESS) --log-level $(LOG_LEVEL)
REPORTS = $(WORK)/reports
# This fragment folder's parent (scripts are found through it), e.g. "pipelines".
PIPELINES := $(patsubst %/stages/,%,$(dir $(lastword $(MAKEFILE_LIST))))
# $(call pg_report,NAME): the run report of one job, gathered by the `report` target.
pg_report = --report $(REPORTS)/$(1).report.json

# The tools write atomically (temporary name, then rename), so a killed job leaves no half-written
# target; make also removes a target whose command failed, and `make` resumes where it stopped.
.DELETE_ON_ERROR:
.SUFFIXES:
MAKEFLAGS += --no-builtin-rules --no-builtin-variables

# Output folders: order-only prerequisites (`| $(dir $@)`) so a folder's mtime never triggers work.
$(WORK)/%/:
	mkdir -p $@

# Consecutive pairs of a list of ids: $(call pg_consecutive_pairs,a b c) = a:b b:c.
pg_consecutive_pairs = $(join $(addsuffix :,$(filter-out $(lastword $(1)),$(1))),$(wordlist 2,$(words $(1)),$(1)))
# Starts (0-based) of chunks of $(2) items out of the list $(1): 0 2 4 ...
pg_chunk_starts = $(shell seq 0 $(2) $(words $(wordlist 2,$(words $(1)),$(1))))
# The items of the chunk starting at $(2) (0-based), $(3) items long, of the list $(1).
pg_chunk = $(wordlist $(shell echo $$(($(2) + 1))),$(shell echo $$(($(2) + $(3)))),$(1))
endif
