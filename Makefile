# proxyshade: `make demo` runs the demo graph on a bundled sample, `make test` runs the tests.
# Both create .venv and install the package when needed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

# The first frame of each bundled scene (EXR + previews in out/first_frame), the farm
# scene composited with its CG house, shadow, fog and Cryptomatte (out/composite), and the
# first 12 frames of the lake's temporally coherent camera move (out/camera_move).
# 'proxyshade compile' first: numba compiles the kernels once into its cache, with progress.
demo: $(STAMP)
	$(VENV)/bin/proxyshade compile
	$(VENV)/bin/proxyshade run graphs/first_frame.yaml --frames 1 --var scene=lake --var source=renoir
	$(VENV)/bin/proxyshade run graphs/first_frame.yaml --frames 1 --var scene=cliffs --var source=monet
	$(VENV)/bin/proxyshade run graphs/first_frame.yaml --frames 1 --var scene=farm --var source=creek
	$(VENV)/bin/proxyshade run graphs/composite.yaml --frames 1
	$(VENV)/bin/proxyshade run graphs/camera_move.yaml --frames 1-12
	$(VENV)/bin/proxyshade run graphs/relight.yaml --frames 1
	$(VENV)/bin/proxyshade run graphs/annotated.yaml  # the lake's vegetation from annotated creek, lit and shaded, in the frame
	$(VENV)/bin/proxyshade run graphs/btf_move.yaml  # BTF-shaded plane, 12 frames: out/btf_move/*.png and move.gif
	$(VENV)/bin/proxyshade run graphs/hybrids.yaml --frames 1  # hybrids of the bundled sets: out/hybrids/*.png
	@echo "demo output: out/first_frame/*.png, out/composite/farm_creek.0001.png, out/camera_move/lake_renoir/*.png (and move.gif, the shot as a movie), out/relight/lake_renoir_relit.0001.png (the lake relit from a graded photo), out/annotated/lake_creek_annotated.0001.png (annotated synthesis in the lake's frame), out/hybrids/*.png (structured image hybrids), out/btf_move/move.gif (a BTF-shaded plane) and their EXRs"

test: $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) bench/run.py

clean:
	rm -rf out .proxyshade graphs/.proxyshade  # caches of older versions; today's: proxyshade cache clean
