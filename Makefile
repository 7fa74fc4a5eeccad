SHELL := /bin/bash

# The two commands of the README:
#   make demo   installs what is missing, builds, renders the built-in Cornell box (clustered and
#               the unclustered reference), compares them, and verifies the GPU twin against the CPU.
#   make test   installs what is missing, builds and runs every test.
# Both run ci/install-deps.sh first (idempotent: apt packages, the Embree 4 runtime).

CARGO ?= cargo
DEMO_OUT ?= out/demo
# The stages and their parts, read from the stage table (crates/vplgi-frame/src/stages.rs: one
# row per line, `name Trait [part Trait, ...],`); tests/tests/stages.rs checks this reading.
STAGE_TABLE := crates/vplgi-frame/src/stages.rs
STAGES := $(shell sed -n 's/^ *\([a-z_]*\) [A-Z][A-Za-z]* \[.*\],$$/\1/p' $(STAGE_TABLE))
STAGE_MODULES := $(shell sed -n 's/^ *\([a-z_]*\) [A-Z][A-Za-z]* \[\(.*\)\],$$/\1,\2/p' $(STAGE_TABLE) | tr ',' '\n' | awk 'NF {print $$1}')
VPLGI := target/release/vplgi

.PHONY: stages cli-doc all setup build demo test verify-long fuzz mutants bench bench-baseline perf-report references results variants rsm photons validate test-slurm clean

all: build

setup:
	@bash ci/install-deps.sh

build: setup
	$(CARGO) build --release --workspace

demo: build
	$(VPLGI) render --out $(DEMO_OUT)/clustered
	$(VPLGI) render --cluster none --width 256 --height 256 --out $(DEMO_OUT)/reference-256
	$(VPLGI) render --width 256 --height 256 --out $(DEMO_OUT)/clustered-256
	$(VPLGI) compare $(DEMO_OUT)/reference-256/image.exr $(DEMO_OUT)/clustered-256/image.exr --out $(DEMO_OUT)/compare-256
	XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}" $(VPLGI) verify --out $(DEMO_OUT)/verify
	@echo
	@echo "Pictures:"
	@echo "  $(DEMO_OUT)/clustered/image.png         the default render (512x512, --cluster both, 1k VPL / 8k SP clusters)"
	@echo "  $(DEMO_OUT)/reference-256/image.png     the unclustered reference (--cluster none) at 256x256"
	@echo "  $(DEMO_OUT)/compare-256/error_map.png   FLIP error map of the clustered 256x256 render against it"
	@echo "  $(DEMO_OUT)/verify/verify.html          vplgi verify: every GPU stage against the CPU, images and error maps per mode"
	@echo "Reports: report.json beside each image (parameters, counts, per-stage timings), $(DEMO_OUT)/compare-256/compare.json"

# Tests run on the release profile: rayon code is ~30x slower unoptimised, and the demo's build
# artifacts are reused. Every step selects the whole workspace (--workspace) and narrows by target
# or test name: selecting packages with -p would change cargo's feature unification and rebuild
# wgpu and naga for each step. Steps, cheapest and most telling first:
#   1. formatting and clippy (warnings are errors);
#   2. WGSL validation: every composed shader through naga, and the Rust/WGSL layout tests;
#   3. unit tests of every crate and the CPU-only integration tests;
#   4. the CPU-vs-GPU integration tests (every other file in tests/tests/, on lavapipe here);
#   5. every criterion bench once at tiny sizes (proof that they work, not a measurement);
#   6. each fuzz target for 20 seconds from its seeds (proof that it builds and runs).
# The Vulkan loader complains when XDG_RUNTIME_DIR is unset (harmless): give it a private one.
TEST_ENV := XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}"
TEST := $(TEST_ENV) $(CARGO) test --release --workspace
CPU_TESTS := analytic edge_cases path_tracer_oracle regression cli faults results variants rsm photons perf_report repository stages
# The GPU tests: every differential test in tests/tests/, and `vplgi verify` as a user runs it
# (crates/vplgi-cli/tests/verify.rs, with its report loaded in headless chromium).
GPU_TESTS := $(filter-out $(CPU_TESTS),$(basename $(notdir $(wildcard tests/tests/*.rs)))) verify
test: setup
	$(CARGO) fmt --all --check
	$(CARGO) clippy --release --workspace --all-targets -- -D warnings
	$(TEST) --lib -- shader:: layouts
	$(TEST) --lib --bins $(addprefix --test ,$(CPU_TESTS)) -- --skip shader:: --skip layouts
	$(TEST) $(addprefix --test ,$(GPU_TESTS))
	$(TEST_ENV) VPLGI_BENCH_SMOKE=1 $(CARGO) test --release --workspace --benches
	$(MAKE) --no-print-directory fuzz FUZZ_SECONDS=20

# Every stage's property test (random scenes, point sets and rays against the SPEC's tolerance
# table, through vplgi-verify's comparisons) at 10,000 cases each instead of make test's few.
# Override with VPLGI_PROPTEST_CASES=N. Shrunk failures are written next to the test file
# (tests/tests/<stage>.proptest-regressions): commit them, every later run replays them first.
PROPERTY_TESTS := rng $(STAGES)
verify-long: setup
	@for t in $(PROPERTY_TESTS); do \
	  start=$$(date +%s); \
	  $(TEST_ENV) VPLGI_PROPTEST_CASES=$${VPLGI_PROPTEST_CASES:-10000} $(CARGO) test -q --release --workspace --test $$t -- --test-threads 1 rng_streams random grazing || exit 1; \
	  echo "verify-long: $$t passed in $$(( $$(date +%s) - start )) s"; \
	done

# Mutation testing (cargo-mutants 27.1.0, installed on first use): every mutant of vplgi-types and
# of the CPU stage modules is built and run against the tests that cover that code (the unit tests,
# the tests that compute the paper's equations independently, the analytic and path-traced
# oracles, the committed references, and the CPU-vs-GPU tests). Survivors are written to
# docs/MUTANTS.md, each with why it is harmless (ci/mutants-harmless.tsv) or marked unexplained.
# The selection is thousands of mutants, many hours on 2 cores: longer than a working session. So
# outcomes accumulate in the committed ledger ci/mutants-ledger.tsv, each keyed by a hash of the
# text of the function it mutated; a run tests only mutants without a valid outcome (a function's
# outcomes lapse when its text changes, not when other code in its file does) and records what it
# learned even when stopped, so runs add up across machines and sessions. MUTANTS_MINUTES=N stops
# a run after N minutes (0: no limit); MUTANTS_RETEST=1 tests again the recorded survivors that
# ci/mutants-harmless.tsv does not explain (after adding tests); MUTANTS_FILES="a.rs b.rs" narrows
# a run to some of the files, while docs/MUTANTS.md always reports the whole selection. Commit
# the ledger and docs/MUTANTS.md after.
# The run tests HEAD (commit first): cargo-mutants mutates, in place, a git worktree of HEAD under
# target/mutants-tree with its own target folder, so one build serves the baseline, the tool and
# every mutant's incremental rebuild, and the working tree is never touched. Tests run under
# nextest: every test in its own process, both cores busy, and the run stops at the first failure
# (a mutant most tests catch costs a second instead of the whole suite's ~27 s); the test targets
# are cargo arguments, so a mutant's build links only them. Its own baseline
# would run only the mutated packages' tests, so the unmutated tests run first here, with exactly
# the arguments each mutant's run gets (--workspace comes from --test-workspace); and the ledger
# refuses a run whose logs show cargo rejecting those arguments, which would count every mutant
# as caught.
MUTANTS_ALL := crates/vplgi-types/src/*.rs crates/vplgi-shared/src/*.rs $(foreach m,$(STAGE_MODULES),crates/vplgi-cpu/src/$(m).rs)
MUTANTS_TESTS := equations analytic edge_cases path_tracer_oracle regression rng $(STAGES)
MUTANTS_FILES := $(MUTANTS_ALL)
# Property tests draw the same cases for the baseline and every mutant. A failing case is saved to a
# .proptest-regressions file and replayed first for every later mutant, so one that fails without
# any mutant (found by chance with random cases) would count them all as caught: cases saved during
# a run are replayed on the unmutated code before anything is recorded. NEXTEST_PROFILE picks the
# test order and fail-fast of .config/nextest.toml, which only changes how soon a mutant is caught.
MUTANTS_ENV = $(TEST_ENV) PROPTEST_RNG_SEED=20261205 NEXTEST_PROFILE=mutants
# The covering tests on the unmutated tree: before a run, and after one that saved cases.
MUTANTS_BASELINE = cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_ENV) $(CARGO) nextest run --cargo-profile mutants --workspace $(MUTANTS_TARGETS) --status-level fail
MUTANTS_SELECT = --workspace $(foreach f,$(MUTANTS_FILES),-f '$(f)')
MUTANTS_SELECT_ALL = --workspace $(foreach f,$(MUTANTS_ALL),-f '$(f)')
MUTANTS_TARGETS := --lib $(addprefix --test ,$(MUTANTS_TESTS))
MUTANTS_TREE := target/mutants-tree
MUTANTS_OUT := ../mutants-report
MUTANTS_LEDGER := ../../ci/mutants-ledger.tsv
MUTANTS_HARMLESS := ../../ci/mutants-harmless.tsv
MUTANTS_MINUTES ?= 0
MUTANTS_RETEST ?=
MUTANTS_TOOL = $(CARGO) run -q --profile mutants -p vplgi-reports --bin mutants_report --
mutants: setup
	@command -v cargo-mutants >/dev/null 2>&1 || cargo install --locked --quiet cargo-mutants --version 27.1.0
	@command -v cargo-nextest >/dev/null 2>&1 || cargo install --locked --quiet cargo-nextest
	@git worktree prune; if [ -d $(MUTANTS_TREE) ]; then git -C $(MUTANTS_TREE) checkout -q -f --detach $$(git rev-parse HEAD) \
	  && git -C $(MUTANTS_TREE) clean -q -f -d; else git worktree add -q --detach $(MUTANTS_TREE) HEAD; fi; mkdir -p target/mutants-report
	@echo "make mutants: testing HEAD ($$(git rev-parse --short HEAD)) in $(MUTANTS_TREE)"
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR cargo mutants $(MUTANTS_SELECT) --list --json > $(MUTANTS_OUT)/all-mutants.json
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_TOOL) prepare $(MUTANTS_LEDGER) $(MUTANTS_OUT) $(if $(MUTANTS_RETEST),--retest-survivors $(MUTANTS_HARMLESS))
	$(MUTANTS_BASELINE)
	@cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_ENV) timeout -s INT $(MUTANTS_MINUTES)m cargo mutants $(MUTANTS_SELECT) \
	  --in-place --iterate --baseline skip --timeout 300 --build-timeout 1200 --profile mutants --test-workspace true --test-tool nextest \
	  $(addprefix --cargo-arg=,$(MUTANTS_TARGETS)) -o $(MUTANTS_OUT); \
	  rc=$$?; case $$rc in 0|2|3) ;; 124) echo "make mutants: stopped after $(MUTANTS_MINUTES) minutes; recording what it tested";; *) exit $$rc;; esac
	@new=$$(git -C $(MUTANTS_TREE) status --porcelain --untracked-files=all -- '*.proptest-regressions'); if [ -n "$$new" ]; then \
	  echo "make mutants: property tests saved failing cases during the run ($$new); replaying them on the unmutated code"; \
	  $(MUTANTS_BASELINE) \
	  || { echo "make mutants: a saved case fails without any mutant, so every mutant tested after it may be caught by it alone: nothing recorded; fix the failure first (the case is in $(MUTANTS_TREE))" >&2; exit 1; }; fi
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_TOOL) record $(MUTANTS_LEDGER) $(MUTANTS_OUT)
	mkdir -p target/mutants-report/all
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR cargo mutants $(MUTANTS_SELECT_ALL) --list --json > $(MUTANTS_OUT)/all/all-mutants.json
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_TOOL) prepare $(MUTANTS_LEDGER) $(MUTANTS_OUT)/all
	cd $(MUTANTS_TREE) && env -u CARGO_TARGET_DIR $(MUTANTS_TOOL) report $(MUTANTS_LEDGER) $(MUTANTS_OUT)/all $(MUTANTS_HARMLESS) ../../docs/MUTANTS.md

# Coverage-guided fuzzing (cargo-fuzz, libFuzzer, nightly) of what users feed vplgi: the glTF
# loader (gltf_load) and the EXR reader of compare and merge (exr_read), FUZZ_SECONDS each
# (default 30 minutes). The corpus grows in fuzz/corpus/ (not committed); a crash is saved in
# fuzz/artifacts/<target>/ and stops the run. The seeds are in fuzz/seeds/. See fuzz/README.md.
FUZZ_TARGETS := gltf_load exr_read
FUZZ_SECONDS ?= 1800
fuzz: setup
	@for t in $(FUZZ_TARGETS); do \
	  mkdir -p fuzz/corpus/$$t fuzz/target; \
	  log=fuzz/target/$$t.log; \
	  if (cd fuzz && cargo +nightly fuzz run -O $$t corpus/$$t seeds/$$t -- -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1) > $$log 2>&1; then \
	    echo "fuzz $$t: $$(grep -E '^Done [0-9]+ runs' $$log), no crash (log: $$log)"; \
	  else \
	    tail -40 $$log; echo "fuzz $$t failed: see $$log and fuzz/artifacts/$$t/"; exit 1; \
	  fi; \
	done

# Criterion benches of every stage, CPU and GPU, small and paper size (about 10 minutes on 2 cores
# with lavapipe). One stage: make bench BENCH=visibility (a stage of the table, or frame). The first run saves its times as the
# baseline BENCH_BASELINE (target/criterion/.../main); later runs are compared with it, and
# bench_compare prints each benchmark as slower, faster or within the noise it measured (the two
# medians' 95 % intervals). make bench-baseline saves the current code's times as the baseline.
BENCH_BASELINE ?= main
BENCH_ENV = XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}"
# The bench target and criterion's filter for BENCH: the stages share one binary.
BENCH_ARGS = $(if $(filter frame,$(BENCH)),--bench frame --,$(if $(BENCH),--bench stages -- '^$(BENCH)/',--))
bench: setup
	@start=$$(date +%s); \
	if find target/criterion -type d -name $(BENCH_BASELINE) 2>/dev/null | grep -q .; then \
	  $(BENCH_ENV) $(CARGO) bench -p vplgi-benches $(BENCH_ARGS) --baseline-lenient $(BENCH_BASELINE) || exit 1; \
	  $(CARGO) run -q --release -p vplgi-reports --bin bench_compare -- --baseline $(BENCH_BASELINE) --since $$start; \
	else \
	  $(BENCH_ENV) $(CARGO) bench -p vplgi-benches $(BENCH_ARGS) --save-baseline $(BENCH_BASELINE) || exit 1; \
	  echo "make bench: no baseline '$(BENCH_BASELINE)' yet: these times are saved as it; the next make bench compares with them"; \
	fi

bench-baseline: setup
	$(BENCH_ENV) $(CARGO) bench -p vplgi-benches $(BENCH_ARGS) --save-baseline $(BENCH_BASELINE)

# vplgi side by side with faiss-cpu (k-means), raw Embree (visibility), its GPU backend and its
# unclustered reference, in one run: docs/PERFORMANCE.md. About 5 minutes. faiss-cpu is
# installed from PyPI under target/ (nothing system-wide).
PERF_PY := target/perf-python
perf-report: build
	@test -d $(PERF_PY)/faiss || python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore --target $(PERF_PY) "faiss-cpu==1.15.1" "numpy<3"
	XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}" PYTHONPATH=$(PERF_PY) $(CARGO) run --release -p vplgi-reports --bin perf_report -- --out docs/PERFORMANCE.md

# The small references the regression tests compare against (tests/tests/regression.rs), made
# with the CPU reference: 128x128, 1,000 VPLs, 16 seeds, for the built-in Cornell box and the
# two generated rooms (20,000 triangles), unclustered and in the default clustered mode (both
# point sets clustered, F = 6 weighted, at 250 VPL / 1,500 shading-point clusters for this
# size). Say why they change: make references WHY="..."
REF_DIR := fixtures/references
REF_ARGS := --width 128 --height 128 --vpls 1000 --seeds 16
CLUSTERED := --cluster both --k-vpl 250 --k-sp 1500
references: build
	@test -n "$(WHY)" || { echo 'say why the references change: make references WHY="..."'; exit 1; }
	mkdir -p target/fixture-scenes
	$(VPLGI) scene generate conference --triangles 20000 --out target/fixture-scenes/conference.glb
	$(VPLGI) scene generate living-room --triangles 20000 --out target/fixture-scenes/living-room.glb
	$(VPLGI) reference $(REF_ARGS) --why "$(WHY)" --out $(REF_DIR)/cornell-box
	$(VPLGI) reference target/fixture-scenes/conference.glb $(REF_ARGS) --why "$(WHY)" --out $(REF_DIR)/conference
	$(VPLGI) reference target/fixture-scenes/living-room.glb $(REF_ARGS) --why "$(WHY)" --out $(REF_DIR)/living-room
	$(VPLGI) reference $(REF_ARGS) $(CLUSTERED) --why "$(WHY)" --out $(REF_DIR)/cornell-box-clustered
	$(VPLGI) reference target/fixture-scenes/conference.glb $(REF_ARGS) $(CLUSTERED) --why "$(WHY)" --out $(REF_DIR)/conference-clustered
	$(VPLGI) reference target/fixture-scenes/living-room.glb $(REF_ARGS) $(CLUSTERED) --why "$(WHY)" --out $(REF_DIR)/living-room-clustered
	rm -f $(REF_DIR)/*/mean.png

# The paper's table on the three generated scenes at the paper's resolutions and VPL counts,
# and on the mirror, glass and rough-metal Cornell boxes at 512x512: docs/RESULTS.md. About 35 minutes of CPU
# frames on 2 cores (the unclustered references dominate) and 30 of GPU frames on lavapipe.
# RESULTS_ARGS=--cpu-only skips the GPU frames; RESULTS_ARGS=--reuse keeps frames already in
# target/results (after an interrupted run); RESULTS_ARGS=--scenes=a,b reruns some scenes and
# keeps the others' rows.
results: build
	XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}" $(CARGO) run --release -p vplgi-reports --bin results -- --out docs/RESULTS.md $(RESULTS_ARGS)

# The core paper's and Wang et al.'s shading-point choices (seeding, metric, representative,
# fuzzy visibility or interpolation) at equal time on the three generated scenes, one
# `vplgi sweep --figure variants` each on the CPU, and flicker along a camera walk of each with
# and without --temporal on: docs/VARIANTS.md. About ten minutes.
variants: build
	$(CARGO) run --release -p vplgi-reports --bin variants -- --out docs/VARIANTS.md

# Prutkin et al.'s shadow-map clusters lit as clamped points, as disks through their Eq. 2 and
# as disks through the exact form factor, against converged references of the Cornell box and
# the sun-lit living room (error and light kept), and the clustering's time at the paper's
# Table 1 sizes on the CPU and on lavapipe: docs/RSM.md. About 15 minutes.
rsm: build
	XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}" $(CARGO) run --release -p vplgi-reports --bin rsm -- --out docs/RSM.md

# Wang et al.'s Figure 6 ablation on the generated cornell-glass and conference scenes (the
# illumination cut and the interpolation each against a 1,024-ray gather from the full photon
# map at every pixel, cuts of 1k to 16k nodes) and the cut's speed against a density estimate at
# every gather hit, on the CPU; and Table 1's stand-ins per stage on the CPU and the GPU:
# docs/PHOTONS.md. About ten minutes.
photons: build
	XDG_RUNTIME_DIR="$${XDG_RUNTIME_DIR:-$$(mktemp -d)}" $(CARGO) run --release -p vplgi-reports --bin photons -- --out docs/PHOTONS.md

# vplgi's references against Mitsuba 3 (PyPI, scalar_rgb: CPU only, no LLVM or GPU), installed
# under target/ with numpy (nothing system-wide): each scene exported with `vplgi scene export
# --format mitsuba`, rendered by Mitsuba and by vplgi (compensated, and clamped for the diffuse
# four), compared per channel and per third of the image against both images' noise; the mirror,
# glass and metal Cornell boxes beside the matte twins of the first two: docs/VALIDATION.md.
# About 55 minutes on 2 cores (64 seeds per scene at 128x90); VALIDATE_ARGS="--scenes a,b" reruns
# some scenes and keeps the others' rows; a quick, noisier check:
# make validate VALIDATE_ARGS="--scenes cornell-box --seeds 2"
MITSUBA_PY := target/mitsuba-python
validate: build
	@test -d $(MITSUBA_PY)/mitsuba || python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore --target $(MITSUBA_PY) "mitsuba==3.9.1" "numpy<3"
	PYTHONPATH=$(MITSUBA_PY) $(CARGO) run --release -p vplgi-reports --bin validate -- --out docs/VALIDATION.md $(VALIDATE_ARGS)

# References past one machine (opt-in, not in make test; needs root or sudo): starts a single-node
# Slurm cluster (Debian's slurm-wlm and munge, installed if missing) in target/slurm-test, submits
# ci/slurm/submit-reference.sh's tile array and dependent merge, and checks the merged reference is
# bit-identical to one run; then checks the Kubernetes manifests in ci/kubernetes and runs their
# pods' commands locally (no cluster is reachable here, so Kubernetes itself is not exercised).
test-slurm: build
	bash ci/slurm/test.sh $(VPLGI)
	/usr/bin/python3 ci/kubernetes/test-commands.py $(VPLGI) target/k8s-test

clean:
	$(CARGO) clean
	rm -rf out

# The stage table as the make targets read it: the stages, then every stage and part module.
stages:
	@echo $(STAGES)
	@echo $(STAGE_MODULES)

# docs/CLI.md: every command's --help, written from clap's definitions (a test fails when stale).
cli-doc:
	VPLGI_WRITE_CLI_DOC=1 $(CARGO) test -q --release -p vplgi-cli --bin vplgi cli_doc
