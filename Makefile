# `make demo`: set everything up and run the main job.  `make test`: set up and run the suite.
PY := .venv/bin/python

.PHONY: setup setup-test demo test bench clean
setup:
	./scripts/setup.sh

setup-test:
	./scripts/setup.sh test

demo: setup
	$(PY) examples/make_dataset.py

test: setup-test
	$(PY) -m pytest -q tests

bench: setup-test
	for b in benchmarks/*.py; do $(PY) $$b || exit 1; done

clean:
	rm -rf .venv build *.egg-info .pytest_cache
