"""Benchmarks and figures of record: `rw-fdi bench ...`."""
