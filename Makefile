# haustra: the two commands (README): `make demo` and `make test`.
# Each installs what is missing (Debian packages, through scripts/install-deps.sh), configures,
# builds and runs. Everything else here is for developers.

JOBS ?= $(shell nproc)
DEMO_OUT ?= out/demo
BIN := build/release/bin

.PHONY: all deps configure build demo view reference anatomy import-asan test test-release test-gate gate-baseline test-asan test-tsan python python-asan results bench bench-quick bench-peers validate stability-doc study studies-doc studies-check skinning-doc figures viewer-shots bench-view soak fuzz clean

all: build

deps:
	@./scripts/install-deps.sh

configure: deps
	@cmake --preset release >/dev/null

build: configure
	@cmake --build --preset release -j $(JOBS)

demo: build
	@$(BIN)/haustra run scenes/demo.toml --out $(DEMO_OUT)
	@echo
	@echo "demo outputs: $(abspath $(DEMO_OUT))/ (summary.json, frames.csv, nodes.csv, mesh/ deformed meshes, mesh.glb animation)"

# The interactive viewer on the demo: grasp the rectum with the mouse (docs/guide.md, "The viewer").
view: build
	@$(BIN)/haustra view scenes/demo.toml

# The Python module, built with the release tree (its tests run in `make test`, as ctest's `python`).
python: build
	@echo "python module: $(abspath build/release/python)/haustra — PYTHONPATH=$(abspath build/release/python) /usr/bin/python3 -c 'import haustra'"

# The Python API reference (docs/reference: Sphinx's autodoc over the module's docstrings), in build/release/reference.
reference: build
	@PYTHONPATH=$(abspath build/release/python) sphinx-build -q -E -b html docs/reference build/release/reference
	@echo "API reference: $(abspath build/release/reference)/index.html"

# Once, by hand: every import test (CGAL) under ASan+UBSan; `make test` runs the quick ones there.
import-asan: deps
	@cmake --preset asan >/dev/null
	@cmake --build --preset asan -j $(JOBS) --target haustra_import_tests
	@build/asan/bin/haustra_import_tests

# Once, by hand: the module and the pytest suite under ASan+UBSan (views outliving their world).
python-asan: deps
	@cmake --preset asan -B build/asan-python -DHAUSTRA_PYTHON=ON >/dev/null
	@cmake --build build/asan-python -j $(JOBS) --target haustra_python haustra_python_stubs haustra
	@PYTHONPATH=$(abspath build/asan-python/python) HAUSTRA_BIN=$(abspath build/asan-python/bin/haustra) \
	  HAUSTRA_SOURCE=$(abspath .) MPLBACKEND=Agg ASAN_OPTIONS=detect_leaks=0 \
	  LD_PRELOAD="$$(gcc -print-file-name=libasan.so) $$(gcc -print-file-name=libubsan.so)" \
	  /usr/bin/python3 -m pytest -q -p no:cacheprovider $(abspath python/tests)

# docs/results.md: the reference cases, the figures the tests assert, the last `make bench`.
results: build
	@/usr/bin/python3 scripts/results.py build/release docs/results.md
	@/usr/bin/python3 scripts/pages.py stamp docs/results.md

# Release tests and the instruction-count gate, then the whole suite under ASan+UBSan and the
# threaded tests under TSan.
test: test-release test-gate test-asan test-tsan

# HAUSTRA_FULL_RUN: every case runs, so every figure on docs/results.md must be measured (decision 0115).
test-release: build
	@HAUSTRA_FULL_RUN=1 ctest --preset release -j $(JOBS)

# Instructions of one `drop` step and one 10k-vertex skinning against bench/baselines (callgrind).
test-gate: build
	@./scripts/instruction-gate.sh

# Records the current instruction counts as the gate's baseline.
gate-baseline: build
	@./scripts/instruction-gate.sh --update

# The sanitizer builds compile only what their tests run (the test binary, the CLI it drives, the
# soak and the fuzz replayers), with line tables only (-g1: enough for a report's stack, a third
# less compile time than full debug information); ASan's as a unity build (the libraries' files in
# batches of 8: Eigen and fmt parsed once per batch), TSan's file by file (decision 0101).
# Not under ASan (decision 0025): the 1-vs-2-thread determinism tests (run in release and, the
# engine's, under TSan), the CLI's re-run of the validation cases (run in-process), the N = 20,000
# stability sweep (the stiff floor's N = 2 and 20 run), and accuracy studies whose code paths other tests run
# under ASan (MVC against quadrature, the localization study, the 50 s catenary, the 900 frames
# of `drop` settling): minutes of sanitizer time; and the import cases that run a whole organ or the
# CT colon for 120 frames, and the several-surfaces cases that import a procedural organ three or
# four times (the repair, layout, axis, cage and a --body import run there in the quick cases; `make
# import-asan` runs them all); the skinning's cost studies (cost limit, mean rings, the dense cage)
# and two of the CT colon's three binding cases (the third builds and checks its binding under ASan),
# the allocation count of every stage on 2 threads (the stages run under ASan in the scenes'
# tests; counting allocations is release's job), the normals against a double-precision sum (the
# kernel runs in every mesh case), the C API's localization fields (the C API's other cases), and the
# stiff floor's frame costs through the C API, whose exact frame counts are release's bits (at -O1
# the floor holds without the robust mode: the limits' code runs under ASan in the failed grasp's case);
# a reader holding a frame while the bowel steps (the frame publisher runs under ASan in the C API's
# double-buffered cases), a chain's mesh file cut per piece (each piece's own mesh is built in another
# chain case), the stability sweep up to N = 2,000 (the stiff floor's N = 2 and 20 run), the bowel
# dragged towards a wall (the bowel scene's grasp runs) and the deadline counts on the demo (the C
# API's deadline case): 90 s of ASan CPU for code paths other cases run there.
ASAN_SKIP = a reader acquiring mid-run holds one whole frame|a chain with a mesh file: each piece gets|stability sweep, N = 2 to 2000|bowel: a loop grasped and dragged|deadline mode: frames over world.frame_budget|settles on the floor without penetrating|goes through the organ protocol and holds|the memory estimate is what building and stepping|with 1 and 2 threads|1 thread, 2 threads|host job system's threads give|validate --json|N = 20000|agree with quadrature|the skin choice: along-rod cheapest|settles on the catenary|import: the CT colon|import: a colon mesh|import: a procedural organ|two loops of one organ touching|import: a wall whose two shells are joined|import: the whole|import: the same surface|import: an imported whole organ|several surfaces: open ends that meet|several surfaces: the same files|a dense cage|a rigid motion of the rod moves the skinned mesh|the CT colon.s rest pose is its input mesh|a step allocates nothing in the scenes that use every stage|vertex normals: unit, area-weighted|a frame.s cost is bounded by the host.s limits
test-asan: deps
	@cmake --preset asan >/dev/null
	@cmake --build --preset asan -j $(JOBS) --target haustra_tests haustra haustra_soak haustra_fuzz_scene \
	  haustra_fuzz_centreline haustra_fuzz_mesh haustra_fuzz_c_api haustra_c_api_tests haustra_example_build_world \
	  haustra_import_tests
	@ctest --preset asan -j $(JOBS) -E "$(ASAN_SKIP)"

# TSan checks what runs on more than one thread: stepping worlds with 2 threads, batches. Its build is
# the one without the unity build (CMakePresets.json, decision 0101): each file compiled on its own, so
# a missing include or name fails here.
# Not under TSan: the allocation count on 2 threads (counting is release's job; the scenes it steps
# run on 2 threads under TSan in the determinism cases: the bowel grasped, fast mode, drop, coil).
TSAN_SKIP = a step allocates nothing in the scenes that use every stage
test-tsan: deps
	@cmake --preset tsan >/dev/null
	@cmake --build --preset tsan -j $(JOBS) --target haustra_thread_tests haustra_c_api_tests
	@ctest --preset tsan -j $(JOBS) -R "thread" -E "$(TSAN_SKIP)"

# The quick set: every suite at its smallest sizes, briefly (under a minute; for a smoke run in CI).
QUICK_FILTER = --benchmark_min_time=0.02 --benchmark_filter='(/16$$|/167$$|/55$$|/10000$$|segments:1/|FrameDrop|StreamTriad/1000000$$)'
bench-quick: build
	@$(BIN)/haustra_bench $(QUICK_FILTER) --benchmark_out=build/release/bench-quick.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_collision $(QUICK_FILTER) --benchmark_out=build/release/bench_collision-quick.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_mesh $(QUICK_FILTER) --benchmark_out=build/release/bench_mesh-quick.json --benchmark_out_format=json
	@echo "benchmark results: $(abspath build/release)/bench{,_collision,_mesh}-quick.json"

bench: build
	@$(BIN)/haustra_bench --benchmark_out=build/release/bench.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_collision --benchmark_out=build/release/bench_collision.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_mesh --benchmark_out=build/release/bench_mesh.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_anatomy --benchmark_out=build/release/bench_anatomy.json --benchmark_out_format=json
	@$(BIN)/haustra_bench_batch --benchmark_out=build/release/bench_batch.json --benchmark_out_format=json
	@PYTHONPATH=$(abspath build/release/python) /usr/bin/python3 python/tools/bench_batch.py --out build/release/bench_batch_python.json
	@echo "benchmark results: $(abspath build/release/bench.json) $(abspath build/release/bench_collision.json) $(abspath build/release/bench_mesh.json) $(abspath build/release/bench_anatomy.json) $(abspath build/release/bench_batch.json) $(abspath build/release/bench_batch_python.json)"

# The same rope in haustra, Bullet and MuJoCo (Debian's), time per frame next to stretch and
# floor penetration. Optional: installs libbullet-dev and libmujoco-dev first.
bench-peers:
	@./scripts/install-deps.sh --peers
	@cmake --preset release >/dev/null
	@cmake --build --preset release -j $(JOBS) --target haustra_bench_peers
	@$(BIN)/haustra_bench_peers

validate: build
	@$(BIN)/haustra validate

# Regenerates docs/stability.md and its heat map docs/figures/stability-map.png.
stability-doc: build
	@./scripts/install-deps.sh --figures
	@mkdir -p out
	@$(BIN)/haustra stability --markdown --csv tests/data/stability-map.csv > docs/stability.md
	@/usr/bin/python3 scripts/plots.py stability tests/data/stability-map.csv docs/figures/stability-map.png
	@/usr/bin/python3 scripts/pages.py stamp docs/stability.md
	@echo "wrote $(abspath docs/stability.md), $(abspath docs/figures/stability-map.png) and the tests' table $(abspath tests/data/stability-map.csv)"

# Regenerates every picture in docs/figures/ (captions in docs/figures/README.md).
figures: build
	@./scripts/install-deps.sh --figures
	@./scripts/figures.sh

# The viewer's pictures of the guide (docs/figures/viewer*.png), scripted under Xvfb.
viewer-shots: build
	@./scripts/viewer-shots.sh

# The viewer's draw rate (frames drawn a second: the demo, and the 6 m small intestine with and
# without multisampling), under Xvfb when there is no display; JSON in build/release.
bench-view: build
	@if [ -n "$$DISPLAY" ]; then run=""; else run='xvfb-run -a -s "-screen 0 1920x1080x24"'; fi; \
	  eval $$run $(BIN)/haustra_bench_view --benchmark_out=build/release/bench_view.json --benchmark_out_format=json
	@echo "draw rates: $(abspath build/release/bench_view.json)"

# Regenerates docs/tradeoff.md and its plot docs/figures/tradeoff.png: the speed-against-accuracy
# study (haustra study), about a minute on this machine.
study: build
	@./scripts/install-deps.sh --figures
	@mkdir -p out
	@$(BIN)/haustra study --markdown --csv out/tradeoff.csv > out/tradeoff.md
	@mv out/tradeoff.md docs/tradeoff.md
	@/usr/bin/python3 scripts/pages.py stamp docs/tradeoff.md
	@/usr/bin/python3 scripts/plots.py tradeoff out/tradeoff.csv docs/figures/tradeoff.png
	@echo "wrote $(abspath docs/tradeoff.md) and $(abspath docs/figures/tradeoff.png)"

# docs/anatomy.md: every surface of ANATOMY imported with the defaults and put through the organ
# protocol: left alone, grasped, pulled 5 cm, released (decision 0097). The surfaces:
# ../shared/data/anatomy (25 real intestines, its README). About half a minute.
# The table replaces the old one only when it is whole (its closing "Columns:" note written and no
# crash): a surface that fails is a row; a crash keeps the old table.
ANATOMY ?= ../shared/data/anatomy
# And the abdomen: the surfaces of one body (ABDOMEN, a prefix) and that body's boundary as one scene.
ABDOMEN ?= EdinGCA-00020
BODY ?= ../shared/data/body/EdinGCA-00020-body.obj
anatomy: build
	@$(BIN)/haustra anatomy $(ANATOMY) --out build/anatomy --abdomen $(ABDOMEN) --body $(BODY) > docs/anatomy.md.new; status=$$?; \
	  if [ $$status -lt 128 ] && grep -q '^Columns:' docs/anatomy.md.new; then \
	    mv docs/anatomy.md.new docs/anatomy.md; /usr/bin/python3 scripts/pages.py stamp docs/anatomy.md; echo "wrote $(abspath docs/anatomy.md)"; \
	  else echo "haustra anatomy stopped (status $$status): docs/anatomy.md kept, the partial table is docs/anatomy.md.new"; \
	    exit 1; fi; exit $$status

# The studies on Dask (docs/studies.md, decision 0070). studies-doc: the cohort study
# (python/studies/cohort.toml: every surface of ../shared/data/anatomy imported, grasped and lifted at
# three stiffnesses) on a 2-worker local cluster, its table docs/studies-cohort.md and plot
# docs/figures/studies-cohort.png; then docs/studies-scaling.json: the cohort on 1 and on 2 workers in
# one run, and the scheduler's cost per cell (scripts/studies-scaling.py). A few minutes.
STUDIES_ENV = PYTHONPATH=$(abspath build/release/python) HAUSTRA_BIN=$(abspath $(BIN)/haustra) MPLBACKEND=Agg
studies-doc: build
	@rm -rf out/studies/cohort
	@$(STUDIES_ENV) /usr/bin/python3 -m haustra.studies run python/studies/cohort.toml --workers 2 \
	  --out out/studies/cohort --quiet || echo "studies-doc: some cells failed; their rows say why"
	@{ echo "<!-- Generated by \`make studies-doc\` on $$(date -u +%F) on $$(hostname); do not edit by hand. -->"; \
	  echo; cat out/studies/cohort/summary.md; echo; \
	  echo "![force against stiffness per surface](figures/studies-cohort.png)"; } > docs/studies-cohort.md
	@/usr/bin/python3 scripts/pages.py stamp docs/studies-cohort.md
	@cp out/studies/cohort/plots.png docs/figures/studies-cohort.png
	@$(STUDIES_ENV) /usr/bin/python3 scripts/studies-scaling.py --out docs/studies-scaling.json
	@echo "wrote $(abspath docs/studies-cohort.md), $(abspath docs/figures/studies-cohort.png) and $(abspath docs/studies-scaling.json)"

# The stability map and the speed/accuracy study run as Dask studies and as `haustra stability` /
# `haustra study`, their tables compared (deterministic columns bit for bit); and the cohort's import
# rows (from the last `make studies-doc`) against docs/anatomy.md. About 3 minutes here.
studies-check: build
	@$(STUDIES_ENV) /usr/bin/python3 scripts/studies-compare.py --workers 2

# Regenerates docs/skinning.md's tables (the localization study and real anatomy).
skinning-doc: build
	@$(BIN)/haustra skinning --markdown > docs/skinning-table.md
	@$(BIN)/haustra skinning --anatomy > docs/skinning-anatomy.md
	@/usr/bin/python3 scripts/pages.py stamp docs/skinning-table.md docs/skinning-anatomy.md
	@echo "wrote $(abspath docs/skinning-table.md) and $(abspath docs/skinning-anatomy.md) (docs/skinning.md copies both)"

# The long soak (docs/reliability.md): 1,000,000 frames of grasp and release on `drop`, about
# 25 minutes on one core; samples in out/soak/soak.csv, plots in docs/figures/soak-*.png.
SOAK_FRAMES ?= 1000000
soak: build
	@./scripts/install-deps.sh --figures
	@mkdir -p out/soak
	@$(BIN)/haustra_soak --frames $(SOAK_FRAMES) --out out/soak/soak.csv
	@/usr/bin/python3 scripts/plots.py soak out/soak/soak.csv docs/figures/soak
	@echo "soak samples: $(abspath out/soak/soak.csv); plots: $(abspath docs/figures)/soak-memory.png, soak-energy.png"

# libFuzzer on the scene reader, the centreline reader, mesh loading and C API call sequences
# (clang from Debian), each
# for FUZZ_SECONDS (300); see scripts/fuzz.sh for where inputs and crashes go.
fuzz:
	@./scripts/install-deps.sh --fuzz
	@cmake --preset fuzz >/dev/null
	@cmake --build --preset fuzz -j $(JOBS) --target haustra_fuzz_scene haustra_fuzz_centreline haustra_fuzz_mesh \
	  haustra_fuzz_c_api
	@./scripts/fuzz.sh

clean:
	rm -rf build out
