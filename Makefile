# `make demo`: set everything up and run the main job.  `make test`: set up and run the suite.
PY := .venv/bin/python

.PHONY: setup setup-test demo test bench clean
setup:
	./scripts/setup.sh

setup-test:
	./scripts/setup.sh test

demo: setup
	$(PY) examples/fit_bunny.py

test: setup-test
	$(PY) -m pytest -q tests

# every benchmark once; the full speed-vs-accuracy sweep takes ~2 h (`$(PY) benchmarks/pareto.py`; bunny alone 30 min)
bench: setup-test
	for b in benchmarks/[!_]*.py; do [ $$b = benchmarks/pareto.py ] && continue; $(PY) $$b || exit 1; done
	$(PY) benchmarks/pareto.py --quick

clean:
	rm -rf .venv build *.egg-info .pytest_cache
