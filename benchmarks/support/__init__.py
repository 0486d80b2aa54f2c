"""Helpers of the benchmark scripts (not benchmarks themselves: `make bench` runs only benchmarks/*.py)."""
