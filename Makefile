# `make demo`: set up the core (no torch) and fit the bunny.  `make test`: set up with the test extras, run the suite.
PY := .venv/bin/python

.PHONY: setup setup-test demo test bench reproduce clean
setup:
	./scripts/setup.sh

setup-test:
	./scripts/setup.sh test

demo: setup
	$(PY) examples/fit_bunny.py

test: setup-test
	$(PY) -m pytest -q tests

# every benchmark once, each writing its figures into results.json; then the documents made from it
bench: setup-test
	for b in benchmarks/[!_]*.py; do case $$b in benchmarks/report.py) continue;; esac; $(PY) $$b || exit 1; done
	$(PY) benchmarks/report.py

# the source reports' experiments at full size, then REPRODUCTION.md
reproduce: setup-test
	$(PY) -m mitnerf experiment all --out out/reproduce
	$(PY) benchmarks/report.py

clean:
	rm -rf .venv build *.egg-info .pytest_cache
