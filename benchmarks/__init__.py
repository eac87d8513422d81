"""The benchmark scripts (run each as ``python benchmarks/NAME.py``; the tests import them as a package)."""
