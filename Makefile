# Glossy: every target creates .venv (pinned requirements.txt) when missing.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.glossy-requirements.txt

.PHONY: demo test lint extension bench clean

$(STAMP): requirements.txt
	@df -Pk . | awk 'NR == 2 && $$4 < 3500000 { printf "make: only %d MB free here; .venv takes about 1.1 GB and make test\x27s Blender chroot about 1.4 GB more\n", $$4 / 1024 > "/dev/stderr" }'
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt
	@cp requirements.txt $(STAMP)

demo: $(STAMP)
	$(PY) tools/demo.py
	$(PY) tools/demo_blender.py

# Two workers, one test file each at a time (module fixtures stay whole); single-threaded
# OpenBLAS, whose idle threads would spin against the other worker. The tests that time
# how fast a stop is (marked serial) run alone afterwards. The Blender chroot for the
# blender-executable tests is made in the background meanwhile (build/debian-blender.log);
# those tests wait for it (tools/debian_blender.py takes turns on a lock).
TEST_WORKERS ?= 2

test: $(STAMP)
	$(VENV)/bin/ruff check .
	@mkdir -p build
	$(PY) tools/debian_blender.py provision --if-possible > build/debian-blender.log 2>&1 &
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -n $(TEST_WORKERS) --dist loadfile -m "not serial"
	$(PY) -m pytest -m serial

lint: $(STAMP)
	$(VENV)/bin/ruff check .

extension: $(STAMP)
	$(PY) tools/build_extension.py

bench: $(STAMP)
	$(PY) benchmarks/envmap.py
	$(PY) benchmarks/brdf.py
	$(PY) benchmarks/prefilter.py
	$(PY) benchmarks/operator_bake.py
	$(PY) benchmarks/exr_codec.py
	$(PY) benchmarks/validate.py
	$(PY) benchmarks/separable.py
	$(PY) benchmarks/lamps.py
	$(PY) benchmarks/sampling.py
	$(PY) benchmarks/sampling_eevee.py
	$(PY) benchmarks/hybrid.py

clean:
	rm -rf build out wheels .pytest_cache .ruff_cache  # build/ holds the Debian Blender chroot
